"""Built-in ArduPilot-Rover-compatible autopilot simulator with Helix-25 physics.

Public API::

    from helixd.sim import SimConfig, SimServer, SimSnapshot, start_embedded
    server, url = start_embedded(SimConfig(noise="none", speedup=10))
    ...  # helixd opens ``url``
    server.inject("rc_loss", duration_s=5)
    server.stop()
"""

from helixd.sim.config import NoiseLevel, SimConfig, Terrain
from helixd.sim.faults import FAULTS, FaultError
from helixd.sim.server import SimServer, start_embedded
from helixd.sim.snapshot import History, HistoryEntry, SimSnapshot

__all__ = [
    "FAULTS",
    "FaultError",
    "History",
    "HistoryEntry",
    "NoiseLevel",
    "SimConfig",
    "SimServer",
    "SimSnapshot",
    "Terrain",
    "start_embedded",
]
