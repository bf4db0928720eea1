"""helixd.actuators: four scroll fractions → PWM on the autopilot's outputs.

:func:`helixd.actuators.factory.make_sink` picks the backend from ``actuation.backend``:
``rc_override`` (default; overrides expire on their own if helixd dies), ``servo``
(DO_SET_SERVO, latched — read :mod:`helixd.actuators.servo`), or ``dry_run`` (logs only; needs
no autopilot).
"""
