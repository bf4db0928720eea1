"""Built-in ArduPilot-Rover-compatible autopilot simulator on the Helix-25 plant.

The fake autopilot (the Rover's own code in :mod:`helixd.sim.firmware`, stepped with the plant
by :mod:`helixd.sim.core`, on the wire through :mod:`helixd.sim.server`) over the plant of
:mod:`helixd.plant`, which it imports and nothing else of helixd above ``config``.

Public API::

    from helixd.sim.sim_config import SimConfig
    from helixd.sim.server import start_embedded
    server, url = start_embedded(SimConfig(noise="none", speedup=10))
    ...  # helixd opens ``url``
    server.inject("rc_loss", duration_s=5)
    server.stop()
"""
