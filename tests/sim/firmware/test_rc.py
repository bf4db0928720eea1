"""The RC input model (helixd.sim.firmware.rc)."""

from __future__ import annotations

import math
import random

from helixd.sim.firmware.rc import NUM_RC_CHANNELS, RcInputs


def test_active_overrides_is_has_override_of_every_channel() -> None:
    """The one-pass reading every loop takes agrees with the channel-by-channel rule for any
    overrides, ages and RC_OVERRIDE_TIME (never, disabled, NaN, seconds)."""
    rnd = random.Random(54)
    for _ in range(500):
        rc = RcInputs([1500] * NUM_RC_CHANNELS)
        rc.override_us = [rnd.choice([0, 0, -1, 1000, 1500, 2000]) for _ in range(NUM_RC_CHANNELS)]
        rc.override_time_s = [rnd.uniform(0.0, 10.0) for _ in range(NUM_RC_CHANNELS)]
        now_s = rnd.uniform(0.0, 12.0)
        timeout_s = rnd.choice([-1.0, 0.0, math.nan, 0.5, 1.0, 3.0])
        expected = tuple(rc.has_override(i, now_s, timeout_s) for i in range(NUM_RC_CHANNELS))
        assert rc.active_overrides(now_s, timeout_s) == expected
