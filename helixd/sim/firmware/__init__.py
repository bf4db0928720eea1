"""The fake ArduPilot Rover's own code: what the firmware does on the vehicle.

Arming and the pilot's radio (:mod:`~helixd.sim.firmware.rover_firmware`,
:mod:`~helixd.sim.firmware.rc`), modes and failsafes, servo outputs and the payload, the
parameters, the guard script's model, the EKF stand-in (:mod:`~helixd.sim.firmware.estimator`),
the mission (its MAVLink item protocol, AP_Mission's current command) and the modes that fly it
(AUTO, GUIDED/RTL/SmartRTL), and the MAVLink messages it builds. :mod:`helixd.sim.core` steps it
beside the plant (:mod:`helixd.plant`); pure: messages and numbers in and out.
"""
