"""The simulator on the wire: a plain pymavlink GCS over real UDP against start_embedded().

Each test checks one ArduPilot Rover behaviour listed in docs/ardupilot.md. Times are measured in
*simulated* time (time_boot_ms / SERVO_OUTPUT_RAW time_usec / the history's sim_time_s), so a
loaded machine slows the simulation down but does not change the numbers.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import pytest
from typer.testing import CliRunner

from helixd.cli.app import app
from helixd.sim.faults import FaultError
from tests.support.harness import (
    FORCE_ARM,
    GCS_SYSID,
    MAV_CMD_COMPONENT_ARM_DISARM,
    MAV_CMD_DO_SET_MODE,
    MAV_CMD_DO_SET_SERVO,
    MAV_CMD_SET_MESSAGE_INTERVAL,
    MAV_RESULT_ACCEPTED,
    MAV_RESULT_DENIED,
    MAV_RESULT_FAILED,
    MAV_RESULT_UNSUPPORTED,
    MODE_HOLD,
    MSG_LOCAL_POSITION_NED,
    UINT16_MAX,
    MavClient,
    client,
    running_sim,
    running_sim_links,
)

pytestmark = pytest.mark.integration

MAV_TYPE_GROUND_ROVER = 10
MAV_AUTOPILOT_ARDUPILOTMEGA = 3
CUSTOM_MODE_ENABLED = 1
SAFETY_ARMED = 128
MAVLINK2_MAGIC = 0xFD


def wait_manual(c: MavClient) -> Any:
    """Booted to MANUAL and settled (EKF origin set, so the boot-time mode-switch read that
    ArduPilot does 200 ms after init is long over)."""
    hb = c.expect("HEARTBEAT", 10.0, lambda m: int(m.custom_mode) == 0)
    c.expect("LOCAL_POSITION_NED", 10.0)
    return hb


def rate_hz(c: MavClient, kind: str, span_ms: int) -> float:
    """Messages per simulated second of ``kind`` over ``span_ms`` of time_boot_ms."""
    first = c.expect(kind, 5.0)
    stamps = [int(first.time_boot_ms)]
    while stamps[-1] - stamps[0] < span_ms:
        stamps.append(int(c.expect(kind, 10.0).time_boot_ms))
    return (len(stamps) - 1) / ((stamps[-1] - stamps[0]) / 1000.0)


def test_heartbeat_contents_and_boot_sequence() -> None:
    with running_sim(boot_duration_s=10.0) as (_, url), client(url) as c:
        first = c.expect("HEARTBEAT", 5.0)
        assert int(first.type) == MAV_TYPE_GROUND_ROVER
        assert int(first.autopilot) == MAV_AUTOPILOT_ARDUPILOTMEGA
        assert int(first.custom_mode) == 16  # INITIALISING
        assert int(first.base_mode) & CUSTOM_MODE_ENABLED
        assert not int(first.base_mode) & SAFETY_ARMED
        assert (first.get_srcSystem(), first.get_srcComponent()) == (1, 1)
        assert first.get_msgbuf()[0] == MAVLINK2_MAGIC
        after = c.expect("HEARTBEAT", 10.0, lambda m: int(m.custom_mode) != 16)
        assert int(after.custom_mode) == 0  # MANUAL, straight after INITIALISING


def test_arm_refused_with_prearm_text_force_accepted() -> None:
    with running_sim(prearm_delay_s=None) as (_, url), client(url) as c:
        wait_manual(c)
        assert c.command(MAV_CMD_COMPONENT_ARM_DISARM, 1) == MAV_RESULT_FAILED
        assert c.wait_text("PreArm: ", 3.0).startswith("PreArm: ")
        assert c.command(MAV_CMD_COMPONENT_ARM_DISARM, 1, FORCE_ARM) == MAV_RESULT_ACCEPTED
        c.expect("HEARTBEAT", 3.0, lambda m: int(m.base_mode) & SAFETY_ARMED)
        assert c.command(MAV_CMD_COMPONENT_ARM_DISARM, 0) == MAV_RESULT_ACCEPTED
        c.expect("HEARTBEAT", 3.0, lambda m: not int(m.base_mode) & SAFETY_ARMED)


def test_unknown_command_unsupported_and_set_mode_needs_custom_flag() -> None:
    with running_sim() as (_, url), client(url) as c:
        wait_manual(c)
        assert c.command(31000) == MAV_RESULT_UNSUPPORTED  # MAV_CMD_USER_1
        assert c.command(MAV_CMD_DO_SET_MODE, 0, MODE_HOLD) == MAV_RESULT_DENIED
        assert c.command(MAV_CMD_DO_SET_MODE, 1, MODE_HOLD) == MAV_RESULT_ACCEPTED
        c.expect("HEARTBEAT", 3.0, lambda m: int(m.custom_mode) == MODE_HOLD)


def test_message_interval_20ms_denied_25ms_granted_at_40hz() -> None:
    with running_sim() as (_, url), client(url) as c:
        default_rate = rate_hz(c, "LOCAL_POSITION_NED", 4000)
        assert default_rate <= 1.5  # slow until a rate is granted
        assert c.request_interval(MSG_LOCAL_POSITION_NED, 20_000) == MAV_RESULT_DENIED
        assert "too fast" in c.wait_text("Requested rate for message ID 32", 3.0)
        assert c.request_interval(MSG_LOCAL_POSITION_NED, 25_000) == MAV_RESULT_ACCEPTED
        c.drain()
        assert 36.0 <= rate_hz(c, "LOCAL_POSITION_NED", 3000) <= 44.0


def test_param_mav_gcs_sysid_exists_and_sysid_mygcs_does_not() -> None:
    with running_sim() as (_, url), client(url) as c:
        wait_manual(c)
        assert c.param_read("MAV_GCS_SYSID") == float(GCS_SYSID)  # set up for helixd
        assert c.param_read("MAV_GCS_SYSID_HI") == 0.0
        assert c.param_read("SYSID_MYGCS", timeout_s=1.0) is None
        c.mav.param_request_list_send(1, 1)
        first = c.expect("PARAM_VALUE", 3.0)
        names = {str(first.param_id)}
        while len(names) < int(first.param_count):
            names.add(str(c.expect("PARAM_VALUE", 3.0).param_id))
        assert {"MAV_GCS_SYSID", "RC_OVERRIDE_TIME", "FS_GCS_ENABLE", "SCHED_LOOP_RATE"} <= names
        assert "SYSID_MYGCS" not in names


def test_override_ignored_from_sysid_1_applied_from_the_gcs_id_while_disarmed() -> None:
    with running_sim() as (srv, url), client(url) as c:
        wait_manual(c)
        c.fast_streams()
        c.mav.srcSystem = 1  # a companion that kept MAVROS's default sysid
        c.override(1700)
        c.mav.srcSystem = GCS_SYSID
        start = c.expect("SERVO_OUTPUT_RAW", 3.0)
        while True:  # one simulated second of outputs: channel 1 never moves
            m = c.expect("SERVO_OUTPUT_RAW", 3.0)
            assert int(m.servo1_raw) == 1500
            if int(m.time_usec) - int(start.time_usec) > 1_000_000:
                break
        assert not srv.history.entries("override_set")
        c.override(1700)
        c.servo(1, 3.0, lambda v: v == 1700)
        assert not srv.snapshot().armed


def test_override_expires_after_rc_override_time() -> None:
    with running_sim() as (srv, url), client(url) as c:
        wait_manual(c)
        c.fast_streams()
        c.override(1700)  # once, then silence: a dead companion
        on = c.servo(1, 3.0, lambda v: v == 1700)
        off = c.servo(1, 10.0, lambda v: v == 1500)
        wire_s = (int(off.time_usec) - int(on.time_usec)) / 1e6
        assert 2.8 <= wire_s <= 3.2
        set_at = srv.history.first("override_set")
        expired = srv.history.first("override_expire")
        assert set_at is not None and expired is not None
        assert expired.sim_time_s - set_at.sim_time_s == pytest.approx(3.0, abs=0.03)


def test_release_semantics_channels_1_to_8_and_9_to_18() -> None:
    params = {"RC_OVERRIDE_TIME": 60.0, "SERVO9_FUNCTION": 59}  # RCIN9 on output 9
    with running_sim(params=params) as (srv, url), client(url) as c:
        wait_manual(c)
        c.fast_streams()
        c.override(1700, 1700, UINT16_MAX, UINT16_MAX, UINT16_MAX, UINT16_MAX, UINT16_MAX,
                   UINT16_MAX, 1800)  # fmt: skip
        c.expect("SERVO_OUTPUT_RAW", 3.0, lambda m: (m.servo1_raw, m.servo9_raw) == (1700, 1800))
        c.override(UINT16_MAX, 0)  # ch1 unchanged, ch2 released at once
        m = c.servo(2, 3.0, lambda v: v == 1500)
        assert int(m.servo1_raw) == 1700
        for keep in (0, UINT16_MAX):  # on 9–18 both mean "unchanged"
            c.override(UINT16_MAX, UINT16_MAX, UINT16_MAX, UINT16_MAX, UINT16_MAX, UINT16_MAX,
                       UINT16_MAX, UINT16_MAX, keep)  # fmt: skip
        c.override(UINT16_MAX, UINT16_MAX, UINT16_MAX, UINT16_MAX, UINT16_MAX, UINT16_MAX,
                   UINT16_MAX, UINT16_MAX, UINT16_MAX - 1)  # fmt: skip
        c.servo(9, 3.0, lambda v: v == 1500)
        releases = [e.details["channel"] for e in srv.history.entries("override_release")]
        assert releases == [2, 9]  # the 0 / UINT16_MAX on channel 9 released nothing


def test_do_set_servo_refused_on_function_73_latched_on_function_0() -> None:
    with running_sim() as (srv, url), client(url) as c:
        wait_manual(c)
        c.fast_streams()
        assert c.param_set("SERVO5_FUNCTION", 73) == 73.0
        assert c.command(MAV_CMD_DO_SET_SERVO, 5, 1700) == MAV_RESULT_FAILED
        assert c.wait_text("ServoRelayEvent: Channel 5", 3.0)
        assert c.command(MAV_CMD_DO_SET_SERVO, 6, 1234) == MAV_RESULT_ACCEPTED
        set_msg = c.servo(6, 3.0, lambda v: v == 1234)
        assert c.command(MAV_CMD_COMPONENT_ARM_DISARM, 1, FORCE_ARM) == MAV_RESULT_ACCEPTED
        assert c.command(MAV_CMD_COMPONENT_ARM_DISARM, 0) == MAV_RESULT_ACCEPTED
        later = c.expect(
            "SERVO_OUTPUT_RAW",
            10.0,
            lambda m: int(m.time_usec) - int(set_msg.time_usec) > 6_000_000,
        )
        assert int(later.servo6_raw) == 1234  # latched after 5 s and after disarm
        assert int(later.servo5_raw) == 1500
        assert not srv.snapshot().armed


def test_hold_does_not_stop_an_overridden_passthrough_output() -> None:
    with running_sim() as (srv, url), client(url) as c:
        wait_manual(c)
        c.fast_streams()
        assert c.command(MAV_CMD_COMPONENT_ARM_DISARM, 1, FORCE_ARM) == MAV_RESULT_ACCEPTED
        c.override(1800)
        c.servo(1, 3.0, lambda v: v == 1800)
        assert c.command(MAV_CMD_DO_SET_MODE, 1, MODE_HOLD) == MAV_RESULT_ACCEPTED
        c.override(1800)
        c.expect("HEARTBEAT", 3.0, lambda m: int(m.custom_mode) == MODE_HOLD)
        m = c.expect("SERVO_OUTPUT_RAW", 3.0)
        assert int(m.servo1_raw) == 1800
        assert srv.snapshot().mode == "HOLD"


def test_rc_loss_fault_gives_radio_failsafe_hold_and_pilot_switch_retakes() -> None:
    with running_sim() as (srv, url), client(url) as c:
        wait_manual(c)
        with pytest.raises(FaultError):
            srv.inject("pilot_takeover", mode="GUIDED")  # no switch position for GUIDED
        with pytest.raises(FaultError):
            srv.inject("no_such_fault")
        srv.inject("rc_loss")
        c.expect("HEARTBEAT", 10.0, lambda m: int(m.custom_mode) == MODE_HOLD)
        assert c.wait_text("Radio Failsafe", 3.0)
        lost = srv.history.first("fault", lambda e: e.details["name"] == "rc_loss")
        fired = srv.history.first("failsafe")
        assert lost is not None and fired is not None
        # RC_FS_TIMEOUT (1 s) + FS_TIMEOUT (1.5 s)
        assert fired.sim_time_s - lost.sim_time_s == pytest.approx(2.5, abs=0.05)
        srv.clear_fault("rc_loss")
        srv.wait_for(lambda s: s.receiver_ok and not s.failsafe_radio, 5.0)
        assert srv.snapshot().mode == "HOLD"  # restoring the radio does not leave HOLD
        srv.set_rc(8, 1100)  # the pilot flips the mode switch to MODE1 (MANUAL)
        c.expect("HEARTBEAT", 5.0, lambda m: int(m.custom_mode) == 0)


def test_cli_sim_runs_for_a_duration_and_rejects_bad_faults() -> None:
    runner = CliRunner()
    args = ["sim", "--listen", "udpin:127.0.0.1:0", "--speedup", "20", "--noise", "none"]
    ok = runner.invoke(app, [*args, "--duration", "4", "--fault", "stall@1:duration_s=1"])
    assert ok.exit_code == 0, ok.output
    bad = runner.invoke(app, [*args, "--fault", "stall@soon"])
    assert bad.exit_code == 2
    assert "not a number" in bad.output


def test_heartbeats_are_forwarded_between_links_like_ardupilot() -> None:
    """MAVLink_routing: a ground station on link 1 is heard by helixd on link 0."""
    links = ["udpin:127.0.0.1:0", "udpin:127.0.0.1:0"]
    with running_sim_links(links) as srv:
        url0, url1 = (f"udpout:127.0.0.1:{p}" for p in srv.local_ports)
        with client(url0, sysid=GCS_SYSID) as ours, client(url1, sysid=255) as gcs:
            wait_manual(ours)
            ours.heartbeat()  # link 0 is active from here on

            def from_gcs(m: Any) -> bool:
                return int(m.get_srcSystem()) == 255

            deadline = time.monotonic() + 5.0
            seen = None
            while seen is None and time.monotonic() < deadline:
                gcs.heartbeat()
                seen = ours.recv("HEARTBEAT", 0.3, from_gcs)
            assert seen is not None, "the ground station's HEARTBEAT was not forwarded"
            assert int(seen.get_srcComponent()) == 190 and int(seen.type) == 6
            # and never echoed back to where it came from
            assert gcs.recv("HEARTBEAT", 0.5, from_gcs) is None


async def test_helixd_asks_for_granted_rates_without_a_too_fast_text() -> None:
    """helixd reads SCHED_LOOP_RATE first: no DENIED, no "too fast" STATUSTEXT on start."""
    from helixd.config.link import LinkConfig
    from helixd.config.safety import SafetyConfig
    from helixd.link.connection import Autopilot

    with running_sim() as (srv, url):
        ap = await Autopilot.connect(LinkConfig(url=url, command_timeout_s=0.5), SafetyConfig())
        try:
            await ap.wait_heartbeat(10.0)
            ap.start_heartbeat()
            granted = await ap.request_streams()
            assert granted["LOCAL_POSITION_NED"] == 40.0  # SCHED_LOOP_RATE 50 → 25 ms
            results = [
                e.details["result"]
                for e in srv.history.entries("command")
                if e.details["command"] == MAV_CMD_SET_MESSAGE_INTERVAL
            ]
            assert results and all(r == MAV_RESULT_ACCEPTED for r in results)
            texts = [str(e.details["text"]) for e in srv.history.entries("statustext")]
            assert not any("too fast" in t for t in texts)
        finally:
            ap.stop_heartbeat()
            await ap.close()


RC_RECEIVER_BIT = 0x10000
# the simulator's speed-up while a test streams overrides: times are judged in simulated time
# and the stream is paced by it; 2, not 5, so a loaded machine that holds this thread back
# for a moment does not leave a gap in the overrides the simulator reads as a radio silence
STREAM_SPEEDUP = 2.0
MSG_ATTITUDE = 30


def _stream_overrides_until(
    c: MavClient,
    srv: Any,
    channels: tuple[int, ...],
    until_sim_s: float,
    seen: list[Any],
    stop: Callable[[Any], bool] = lambda m: False,
) -> Any:
    """Stream RC_CHANNELS_OVERRIDE (as helixd does, every 50 ms of its clock: here the
    simulator's) while collecting SYS_STATUS, HEARTBEAT and STATUSTEXT until the simulator's
    clock reaches ``until_sim_s`` or a message satisfies ``stop`` (returned). Each message is
    stamped with the simulated time it was sent at — that of the ATTITUDE (40 Hz) sent just
    before it — not when this thread read it: a loaded machine reads late (it once made a
    SYS_STATUS sent 0.1 s after an event look 0.58 s late)."""
    assert c.request_interval(MSG_ATTITUDE, 25_000) == MAV_RESULT_ACCEPTED
    next_send = 0.0
    stamp: float | None = None
    while (sim_s := srv.snapshot().sim_time_s) < until_sim_s:
        if sim_s >= next_send:
            c.override(*channels)
            next_send = sim_s + 0.05
        kinds = ["ATTITUDE", "SYS_STATUS", "HEARTBEAT", "STATUSTEXT"]
        msg = c.conn.recv_match(type=kinds, timeout=0.01)
        if msg is None:
            continue
        if msg.get_type() == "ATTITUDE":  # the autopilot's clock, on the simulator's scale
            snap = srv.snapshot()
            stamp = int(msg.time_boot_ms) / 1000.0 + snap.sim_time_s - snap.time_boot_ms / 1000.0
            continue
        seen.append((srv.snapshot().sim_time_s if stamp is None else stamp, msg))
        if stop(msg):
            return msg
    return None


def test_a_receiver_that_stops_is_invisible_while_overrides_stream() -> None:
    """As on real ArduPilot (SITL, SIM_RC_FAIL 1 with a GCS overriding channels 1-4: nothing
    changed for 6 s): new overrides count as valid RC input, so Rover's radio failsafe never
    times out, SYS_STATUS keeps the receiver healthy and RC_CHANNELS shows the overrides.
    Before: the simulator reported the loss from the receiver itself, which ArduPilot does not."""
    with running_sim(speedup=STREAM_SPEEDUP) as (srv, url), client(url) as c:
        wait_manual(c)
        seen: list[Any] = []
        t0 = srv.snapshot().sim_time_s
        _stream_overrides_until(c, srv, (1500, 1500, 1500, 1500), t0 + 1.0, seen)
        srv.inject("rc_loss")  # no pulses
        t_lost = srv.snapshot().sim_time_s
        _stream_overrides_until(c, srv, (1500, 1500, 1500, 1500), t_lost + 4.0, seen)
        after = [m for t, m in seen if t >= t_lost + 0.5]
        status = [m for m in after if m.get_type() == "SYS_STATUS"]
        assert status, "no SYS_STATUS after the loss"
        assert all(int(m.onboard_control_sensors_health) & RC_RECEIVER_BIT for m in status)
        assert all(int(m.custom_mode) == 0 for m in after if m.get_type() == "HEARTBEAT")
        assert not [m for m in after if m.get_type() == "STATUSTEXT" and "Failsafe" in m.text]
        rc = c.expect("RC_CHANNELS", 2.0)
        assert int(rc.chancount) == 16 and int(rc.rssi) == 255  # nothing there either


def test_a_receivers_low_throttle_failsafe_is_seen_on_a_channel_not_overridden() -> None:
    """A receiver that keeps sending its failsafe frame (SIM_RC_FAIL 2: the throttle channel
    at 950 µs) below FS_THR_VALUE (960 in the Helix setup): with ArduPilot's throttle channel
    (RCMAP_THROTTLE 5) not overridden, Rover's radio failsafe starts at once (SYS_STATUS
    receiver unhealthy) while overrides stream on 1-4, and acts after FS_TIMEOUT (1.5 s):
    "Radio Failsafe", HOLD."""
    with running_sim(speedup=STREAM_SPEEDUP) as (srv, url), client(url) as c:
        wait_manual(c)
        assert c.param_read("RCMAP_THROTTLE") == 5 and c.param_read("FS_THR_VALUE") == 960
        assert c.request_interval(1, 100_000) == MAV_RESULT_ACCEPTED  # SYS_STATUS at 10 Hz
        seen: list[Any] = []
        helixd_like = (1500, 1500, 1500, 1500)  # channels 1-4; RCMAP_THROTTLE is 5
        t0 = srv.snapshot().sim_time_s
        _stream_overrides_until(c, srv, helixd_like, t0 + 1.0, seen)
        srv.inject("rc_loss", kind="failsafe_values")
        t_lost = srv.snapshot().sim_time_s
        hold = _stream_overrides_until(
            c,
            srv,
            helixd_like,
            t_lost + 5.0,
            seen,
            lambda m: m.get_type() == "HEARTBEAT" and int(m.custom_mode) == MODE_HOLD,
        )
        assert hold is not None, "no HOLD after the receiver's failsafe"
        unhealthy = next(
            t
            for t, m in seen
            if t >= t_lost - 0.03  # a stamp is the ATTITUDE's before it: up to 25 ms early
            and m.get_type() == "SYS_STATUS"
            and not int(m.onboard_control_sensors_health) & RC_RECEIVER_BIT
        )
        fired = srv.history.first("failsafe")
        assert fired is not None
        assert unhealthy - t_lost <= 0.15  # SYS_STATUS's own period: no timeout first
        assert fired.sim_time_s - t_lost == pytest.approx(1.5, abs=0.05)  # FS_TIMEOUT
        texts = [m.text for t, m in seen if m.get_type() == "STATUSTEXT"]
        assert "Radio Failsafe" in texts or c.wait_text("Radio Failsafe", 2.0)
