"""Per-link message intervals: ArduPilot's SET_MESSAGE_INTERVAL rule and stream scheduling."""

from __future__ import annotations

import pytest

from helixd.sim import stream_rates as st


@pytest.mark.parametrize(
    ("interval_us", "loop_hz", "result", "granted_ms"),
    [
        (20_000, 50, st.MAV_RESULT_DENIED, None),  # 50 Hz > 0.8 × 50 Hz
        (24_999, 50, st.MAV_RESULT_DENIED, None),  # integer ms: 24 ms
        (25_000, 50, st.MAV_RESULT_ACCEPTED, 25),  # 40 Hz: the fastest at 50 Hz
        (1_000_000, 50, st.MAV_RESULT_ACCEPTED, 1000),
        (500, 50, st.MAV_RESULT_DENIED, None),  # < 1 ms → 1 ms → too fast
        (11_000, 100, st.MAV_RESULT_DENIED, None),
        (12_000, 100, st.MAV_RESULT_ACCEPTED, 12),  # cap = int(12.5 ms) = 12: not raised
        (0, 50, st.MAV_RESULT_ACCEPTED, 1000),  # default rate (1 Hz here)
        (-1, 50, st.MAV_RESULT_ACCEPTED, 0),  # stop sending
        (-2, 50, st.MAV_RESULT_DENIED, None),
    ],
)
def test_set_message_interval_rule(
    interval_us: int, loop_hz: int, result: int, granted_ms: int | None
) -> None:
    d = st.decide_set_message_interval(
        st.MSG_LOCAL_POSITION_NED, interval_us, 0.0, loop_hz, default_ms=1000
    )
    assert d.result == result
    assert d.interval_ms == granted_ms
    if interval_us in (20_000, 24_999):
        assert d.text == ("Requested rate for message ID 32 too fast. Increase SCHED_LOOP_RATE")


def test_unknown_message_and_param3_are_denied() -> None:
    assert st.decide_set_message_interval(9999, 100_000, 0.0, 50, 0).result == st.MAV_RESULT_DENIED
    d = st.decide_set_message_interval(st.MSG_ATTITUDE, 100_000, 1.0, 50, 0)
    assert d.result == st.MAV_RESULT_DENIED


def count_sent(schedule: st.StreamSchedule, msg_id: int, seconds: float, loop_hz: int) -> int:
    sent = 0
    for n in range(1, round(seconds * loop_hz) + 1):
        if msg_id in schedule.due(n / loop_hz):
            sent += 1
    return sent


def test_default_streams_are_slow_until_granted() -> None:
    schedule = st.StreamSchedule(default_rate_hz=1.0, loop_rate_hz=50)
    assert count_sent(schedule, st.MSG_LOCAL_POSITION_NED, 10.0, 50) in (10, 11)
    schedule = st.StreamSchedule(default_rate_hz=1.0, loop_rate_hz=50)
    assert count_sent(schedule, st.MSG_HEARTBEAT, 10.0, 50) in (10, 11)


def test_granted_25_ms_gives_40_hz_on_a_50_hz_loop() -> None:
    schedule = st.StreamSchedule(default_rate_hz=1.0, loop_rate_hz=50)
    schedule.set_interval(st.MSG_LOCAL_POSITION_NED, 25, 0.0)
    assert count_sent(schedule, st.MSG_LOCAL_POSITION_NED, 10.0, 50) in (399, 400, 401)


def test_request_data_stream_resets_granted_intervals_and_caps_silently() -> None:
    schedule = st.StreamSchedule(default_rate_hz=1.0, loop_rate_hz=50)
    schedule.set_interval(st.MSG_LOCAL_POSITION_NED, 25, 0.0)
    schedule.request_data_stream(6, 2, True, 0.0)  # POSITION at 2 Hz
    assert schedule.interval_ms[st.MSG_LOCAL_POSITION_NED] == 500
    schedule.request_data_stream(0, 100, True, 0.0)  # ALL at 100 Hz: capped to 40 Hz
    assert schedule.interval_ms[st.MSG_ATTITUDE] == 25
    schedule.request_data_stream(10, 5, False, 0.0)  # stop EXTRA1
    assert schedule.interval_ms[st.MSG_ATTITUDE] == 0
    assert count_sent(schedule, st.MSG_ATTITUDE, 5.0, 50) == 0


def test_messages_of_one_interval_go_out_together_in_ap_message_order() -> None:
    """As ArduPilot's deferred-message buckets: POSITION_TARGET_GLOBAL_INT given 200 ms after
    MISSION_CURRENT got it joins its phase, and MISSION_CURRENT (ap_message 11) leaves first
    (62): a mode's mission_mode is read before the mode's place."""
    loop_hz = 50
    schedule = st.StreamSchedule(default_rate_hz=1.0, loop_rate_hz=loop_hz)
    schedule.set_interval(st.MSG_POSITION_TARGET_GLOBAL_INT, 0, 0.0)
    schedule.set_interval(st.MSG_MISSION_CURRENT, 200, 0.0)
    schedule.set_interval(st.MSG_POSITION_TARGET_GLOBAL_INT, 200, 0.06)
    pair = (st.MSG_MISSION_CURRENT, st.MSG_POSITION_TARGET_GLOBAL_INT)
    ticks = []
    for n in range(1, 2 * loop_hz + 1):
        due = [m for m in schedule.due(n / loop_hz) if m in pair]
        if due:
            ticks.append(due)
    assert len(ticks) in (9, 10, 11)  # 5 Hz over 2 s, always both at once
    assert all(due == list(pair) for due in ticks)
