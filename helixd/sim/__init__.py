"""Built-in ArduPilot-Rover-compatible autopilot simulator with Helix-25 physics.

Public API::

    from helixd.sim.sim_config import SimConfig
    from helixd.sim.server import start_embedded
    server, url = start_embedded(SimConfig(noise="none", speedup=10))
    ...  # helixd opens ``url``
    server.inject("rc_loss", duration_s=5)
    server.stop()
"""
