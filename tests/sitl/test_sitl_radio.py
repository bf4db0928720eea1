"""The pilot's radio lost mid-mission on real ArduPilot Rover SITL (opt-in: ``HELIXD_SITL_BIN``).

While a GCS streams RC overrides, ArduPilot counts every new override as fresh RC input: a
receiver that stops sending (``SIM_RC_FAIL 1``) changes nothing it reports. What it still
sees is a receiver that sends its failsafe frame with the throttle channel below
``FS_THR_VALUE`` (``SIM_RC_FAIL 2``: throttle channel 3 at 950 µs), on a throttle channel the
GCS does not override. So here helixd drives the scrolls through RC inputs 9-12 (outputs
9-12, and the model's outputs 1 and 3, on RCIN9..12), leaving ArduPilot's throttle channel 3
to the pilot's receiver, with ``FS_THR_VALUE 960``. Rover's radio failsafe starts at once
(SYS_STATUS: receiver unhealthy); helixd must stop the scrolls within 1 s (cause
``rc_lost``, exit 4) and ask for HOLD, before ArduPilot's own FS_TIMEOUT (1.5 s) would.
Printed: the time from injection to neutral outputs and to HOLD, the distance driven after
it, and the cause helixd reported.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import TYPE_CHECKING

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.base.exitcodes import ExitCode
from tests.sitl import test_sitl_gps as gps  # the same bounds and checks as the GPS fault

if TYPE_CHECKING:
    from tests.sitl.conftest import DaemonRun, SitlVehicle

pytestmark = [pytest.mark.sitl, pytest.mark.timeout(900)]

STATUS_STREAM_HZ = 5.0
RCIN9 = 59  # SERVOn_FUNCTION: RC input 9 passed through
CHANNEL_OFFSET = 8  # helixd's scroll channels 1-4 move to 9-12
RECEIVER_FAILSAFE_US = 950  # what SITL's receiver sends on channel 3 in its failsafe
FS_THR_VALUE_US = 960


def test_radio_lost_stops_the_scrolls_within_1_s(
    sitl: SitlVehicle, launch_helixd: Callable[..., DaemonRun]
) -> None:
    obs = sitl.obs
    for n in range(1, 5):
        # helixd's rule: output 9..12 follows RC input 9..12, which it overrides; the
        # rover-skid model reads outputs 1 and 3, so they follow the same inputs
        obs.set_param(f"SERVO{n + CHANNEL_OFFSET}_FUNCTION", float(RCIN9 + n - 1))
        obs.set_param(f"SERVO{n}_FUNCTION", float(RCIN9 + n - 1))
    obs.set_param("FS_THR_VALUE", float(FS_THR_VALUE_US))
    obs.set_message_interval(int(mavlink.MAVLINK_MSG_ID_SYS_STATUS), STATUS_STREAM_HZ)
    daemon = launch_helixd("rc_override", channel_offset=CHANNEL_OFFSET)
    sitl.wait_driving(daemon, min_distance_m=2.0, timeout_s=gps.DRIVING_TIMEOUT_S)
    before = obs.position()
    assert before is not None

    obs.set_param("SIM_RC_FAIL", 2.0)  # the receiver's failsafe frame: throttle 950 µs
    t0 = time.monotonic()
    t0_boot = before.t_boot_s
    obs.wait_until(
        lambda: any(s.wall_s >= t0 and gps.neutral(s.pwm_us) for s in obs.servo[-50:]),
        gps.STOP_WITHIN_S + gps.LINK_SLACK_S + 5.0,
        "outputs 1 and 3 at trim after the radio loss",
    )
    neutral_s = next(s.wall_s for s in obs.servo if s.wall_s >= t0 and gps.neutral(s.pwm_us)) - t0
    obs.wait_until(lambda: obs.mode() == gps.MODE_HOLD, 10.0, "HOLD after the radio loss")
    hold_s = next(t for t, m in obs.mode_changes if t >= t0 and m == gps.MODE_HOLD) - t0
    code = daemon.wait_exit(gps.EXIT_S)
    log = daemon.log_text()
    time.sleep(gps.SETTLE_S)  # the rover coasts; the distance is taken after it stopped
    track = [p for p in obs.positions if p.t_boot_s >= t0_boot]
    last = track[-1] if track else before
    after_m = math.hypot(last.north_m - before.north_m, last.east_m - before.east_m)
    cause = next(
        (w.split("=", 1)[1] for w in log.split() if w.startswith("cause=")), "none reported"
    )
    print(
        f"radio lost (SIM_RC_FAIL 2, throttle {RECEIVER_FAILSAFE_US} µs < FS_THR_VALUE "
        f"{FS_THR_VALUE_US}): neutral outputs {neutral_s:.2f} s, HOLD {hold_s:.2f} s after "
        f"injection (wall, speedup {sitl.speedup}); {after_m:.2f} m driven after it (EKF); "
        f"cause {cause}"
    )
    assert code == ExitCode.FAULT, log[-4000:]
    assert "event=fallback cause=rc_lost" in log, log[-4000:]
    assert neutral_s <= gps.STOP_WITHIN_S + gps.LINK_SLACK_S
