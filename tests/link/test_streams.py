"""Message intervals: ask for what SCHED_LOOP_RATE grants, step down on DENIED as a fallback,
re-request slow streams."""

from __future__ import annotations

import time

import structlog.testing
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.config.link import LinkConfig
from helixd.link.payload_msgs import PAYLOAD_STREAMS
from helixd.link.streams import (
    TELEMETRY_STREAMS,
    StreamManager,
    candidate_intervals,
    fastest_granted_interval_us,
    first_interval_us,
)
from tests.support.peer import AutopilotPeer, linked, until

SET_INTERVAL = mavlink.MAV_CMD_SET_MESSAGE_INTERVAL
LPN = mavlink.MAVLINK_MSG_ID_LOCAL_POSITION_NED
ATT = mavlink.MAVLINK_MSG_ID_ATTITUDE


def asked(peer: AutopilotPeer, msg_id: int, after_t: float = 0.0) -> list[int]:
    return [
        int(c.params[1])
        for c in peer.records.commands_of(SET_INTERVAL, after_t)
        if int(c.params[0]) == msg_id
    ]


def test_candidates_hit_rovers_fastest_rate_first() -> None:
    assert candidate_intervals(50.0, 5.0, 1.25)[:2] == [20_000, 25_000]
    steps = candidate_intervals(50.0, 5.0, 1.25)
    assert steps == sorted(steps) and steps[-1] <= 200_000 and len(steps) > 5
    assert candidate_intervals(5.0, 5.0, 1.25) == [200_000]


def test_fastest_granted_interval_follows_cap_message_interval() -> None:
    # denied when interval_ms * 800 < 1e6 / SCHED_LOOP_RATE (whole ms)
    assert fastest_granted_interval_us(50) == 25_000  # Rover's default loop: 40 Hz
    assert fastest_granted_interval_us(400) == 4_000  # period 2500 µs → 3.125 → 4 ms
    assert fastest_granted_interval_us(20) == 63_000
    assert fastest_granted_interval_us(0) is None
    assert first_interval_us(50.0, 50) == 25_000
    assert first_interval_us(50.0, 400) == 20_000  # what we want is allowed
    assert first_interval_us(50.0, None) == 20_000
    assert first_interval_us(30.0, None) == 34_000  # rounded up to whole ms


async def test_asks_for_what_sched_loop_rate_grants_no_denied() -> None:
    async with linked(pose_rate_hz=50.0, telemetry_rate_hz=5.0) as (ap, peer):
        granted = await ap.request_streams()
        assert granted["LOCAL_POSITION_NED"] == 40.0 and granted["ATTITUDE"] == 40.0
        assert asked(peer, LPN) == [25_000] and asked(peer, ATT) == [25_000]
        results = [c for c in peer.records.commands if c.command == SET_INTERVAL]
        # one per stream: nothing was DENIED (the payload's too, refused by this peer)
        assert results and len(results) == 10 + len(PAYLOAD_STREAMS)
        assert granted["DISTANCE_SENSOR"] == 0.0  # this peer does not know it
        # the autopilot's HEARTBEAT at 5 Hz (link.autopilot_heartbeat_rate_hz): the arm and
        # the mode seen within 0.2 s, not within ArduPilot's default second
        assert granted["HEARTBEAT"] == 5.0 and peer.heartbeat_asked_us == 200_000
    async with linked(pose_rate_hz=50.0, peer_kwargs={"min_interval_us": 4_000}) as (ap, peer):
        peer.params["SCHED_LOOP_RATE"] = 400.0
        granted = await ap.request_streams()
        assert asked(peer, LPN) == [20_000] and granted["LOCAL_POSITION_NED"] == 50.0


async def test_pose_rate_steps_down_from_denied_20ms_to_granted_25ms() -> None:
    async with linked(pose_rate_hz=50.0, telemetry_rate_hz=5.0) as (ap, peer):
        del peer.params["SCHED_LOOP_RATE"]  # unreadable: the DENIED step-down takes over
        granted = await ap.request_streams()
        assert granted["LOCAL_POSITION_NED"] == 40.0
        assert granted["ATTITUDE"] == 40.0
        for name in TELEMETRY_STREAMS:
            assert granted[name] == 5.0
        assert "MISSION_CURRENT" in TELEMETRY_STREAMS
        assert asked(peer, LPN) == [20_000, 25_000]  # DENIED, then granted
        assert asked(peer, ATT) == [25_000]  # starts from what was granted
        # and the stream really arrives at about 40 Hz
        seen: list[float] = []
        ap.add_message_listener(
            lambda m, t: seen.append(t) if m.get_type() == "LOCAL_POSITION_NED" else None
        )
        await until(lambda: len(seen) >= 21, 3.0, "21 LOCAL_POSITION_NED")
        rate = (len(seen) - 1) / (seen[-1] - seen[0])
        assert 25.0 < rate < 50.0


async def test_step_down_continues_until_granted_and_gives_up_at_the_floor() -> None:
    # a 20 Hz scheduler: fastest interval 1.25 × 50 ms = 62.5 ms
    async with linked(peer_kwargs={"min_interval_us": 62_500}, pose_rate_min_hz=5.0) as (
        ap,
        peer,
    ):
        del peer.params["SCHED_LOOP_RATE"]
        granted = await ap.request_streams()
        steps = asked(peer, LPN)
        assert steps[0] == 20_000 and steps[-1] >= 62_500 and steps[-2] < 62_500
        assert granted["LOCAL_POSITION_NED"] == 1e6 / steps[-1]
    async with linked(peer_kwargs={"min_interval_us": 400_000}, pose_rate_min_hz=5.0) as (
        ap,
        peer,
    ):
        del peer.params["SCHED_LOOP_RATE"]
        granted = await ap.request_streams()
        assert granted["LOCAL_POSITION_NED"] == 0.0  # nothing at or above 5 Hz
        assert max(asked(peer, LPN)) <= 200_000  # never asked below the floor


async def test_slow_stream_is_rerequested_once_per_window() -> None:
    async with linked(stream_check_window_s=0.5, stream_slow_fraction=0.5) as (ap, peer):
        await ap.request_streams()
        t_slow = time.monotonic()
        peer.rate_cap_hz["ATTITUDE"] = 4.0  # e.g. a parameter download eats the bandwidth
        await until(lambda: asked(peer, ATT, t_slow) != [], 3.0, "ATTITUDE re-requested")
        assert asked(peer, ATT, t_slow)[0] == 25_000  # at the granted interval
        await until(lambda: time.monotonic() - t_slow > 2.5, 3.0, "2.5 s of slow ATTITUDE")
        rerequests = asked(peer, ATT, t_slow)
        assert 1 <= len(rerequests) <= 6  # bounded: at most once per 0.5 s window
        assert asked(peer, LPN, t_slow) == []  # the healthy stream is left alone
        del peer.rate_cap_hz["ATTITUDE"]


async def test_one_housekeeping_task_watches_the_link_and_the_streams() -> None:
    # The heartbeat watch and the stream-rate check share one periodic wake-up.
    async with linked(stream_check_window_s=0.5) as (ap, _peer):
        await ap.request_streams()
        assert sorted(t.get_name() for t in ap._tasks) == ["link_housekeeping"]


async def _rerequest_events(
    slow: list[tuple[str, float]], booting: bool
) -> list[dict[str, object]]:
    async def command(*_: object, **__: object) -> int:
        return int(mavlink.MAV_RESULT_ACCEPTED)

    streams = StreamManager(command, LinkConfig())
    for name in ("LOCAL_POSITION_NED", "ATTITUDE", "SYS_STATUS"):
        streams.monitor.grant(name, 10.0, 0.0)
    with structlog.testing.capture_logs() as events:
        await streams.rerequest(slow, booting)
    return events


async def test_an_autopilot_that_boots_gives_one_info_not_a_warning_per_stream() -> None:
    """Before: `serve` logged 16 `stream_slow observed_hz=0.0` while the autopilot booted."""
    silent = [("LOCAL_POSITION_NED", 0.0), ("ATTITUDE", 0.0), ("SYS_STATUS", 0.0)]
    events = await _rerequest_events(silent, booting=True)
    assert [(e["event"], e["log_level"]) for e in events] == [("streams_silent", "info")]
    assert events[0]["streams"] == ["LOCAL_POSITION_NED", "ATTITUDE", "SYS_STATUS"]
    after_boot = await _rerequest_events(silent, booting=False)
    assert [(e["event"], e["log_level"]) for e in after_boot] == [("streams_silent", "warning")]


async def test_one_slow_stream_among_flowing_ones_is_still_named() -> None:
    events = await _rerequest_events([("ATTITUDE", 0.0), ("SYS_STATUS", 3.0)], booting=True)
    assert [(e["event"], e["stream"]) for e in events] == [
        ("stream_slow", "ATTITUDE"),
        ("stream_slow", "SYS_STATUS"),
    ]


def test_a_window_that_saw_the_boot_or_no_origin_names_no_slow_stream() -> None:
    """Before: helixd connecting to an autopilot that still boots (only HEARTBEAT), then has
    no EKF origin yet (no LOCAL_POSITION_NED, as ArduPilot), logged 9 `stream_slow` warnings
    on every run on the simulated clock. A window spent booting starts again once booted; the
    origin's streams are judged once there is one."""

    async def command(*_: object, **__: object) -> int:
        return int(mavlink.MAV_RESULT_ACCEPTED)

    streams = StreamManager(command, LinkConfig(stream_check_window_s=2.0))
    for name in ("LOCAL_POSITION_NED", "ATTITUDE"):
        streams.monitor.grant(name, 40.0, 0.0)
    assert streams.due(1.0, link_up=True, booting=True) is None
    for _ in range(80):  # booted at 1.0 s: ATTITUDE flows at 40 Hz, no pose (no origin)
        streams.monitor.record("ATTITUDE")
    assert streams.due(2.5, link_up=True, origin_known=False) is None  # window from 1.0 s
    assert streams.due(3.0, link_up=True, origin_known=False) is None  # nothing slow
    # the same window with an origin known: the silent pose stream is slow
    for _ in range(80):
        streams.monitor.record("ATTITUDE")
    assert streams.due(5.0, link_up=True, origin_known=True) == [("LOCAL_POSITION_NED", 0.0)]


async def test_payload_streams_are_asked_at_their_rate_and_not_at_zero() -> None:
    """DISTANCE_SENSOR, RANGEFINDER and WATER_DEPTH (payload.csv) are asked for once each at
    link.payload_rate_hz; 0 asks none."""
    ds = int(mavlink.MAVLINK_MSG_ID_DISTANCE_SENSOR)
    async with linked(payload_rate_hz=4.0) as (ap, peer):
        await ap.request_streams()
        assert asked(peer, ds) == [250_000]
    async with linked(payload_rate_hz=0.0) as (ap, peer):
        granted = await ap.request_streams()
        assert asked(peer, ds) == []
        assert not set(PAYLOAD_STREAMS) & set(granted)
