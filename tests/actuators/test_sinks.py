"""Actuator sinks against the peer: override repeat rate and field values, DO_SET_SERVO rules."""

from __future__ import annotations

import asyncio
import time
from collections.abc import Sequence

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink
from structlog.testing import capture_logs

from helixd.actuators.base import ServoCommandRefused
from helixd.actuators.dry_run import DryRunSink
from helixd.actuators.factory import make_sink
from helixd.actuators.rc_override import RcOverrideSink
from helixd.actuators.servo import ServoSink
from helixd.base.clock import now_s
from helixd.config.vehicle import ActuationBackend, ActuationConfig, ChannelConfig, VehicleConfig
from helixd.link.services.command_client import CommandError
from tests.support.peer import HELIXD_SYSID, AutopilotPeer, OverrideRecord, linked, stays, until
from tests.support.simclock import run_simulated

SET_SERVO = mavlink.MAV_CMD_DO_SET_SERVO
LEAVE_LOW, LEAVE_HIGH = 65535, 0  # "leave unchanged" on 1–8 / 9–18
RELEASE_LOW, RELEASE_HIGH = 0, 65534


def actuation(
    backend: ActuationBackend, channels: tuple[int, ...] = (1, 2, 3, 10), **kw: object
) -> ActuationConfig:
    chans = tuple(ChannelConfig(channel=c) for c in channels)
    return ActuationConfig(backend=backend, channels=chans, **kw)


def overrides(peer: AutopilotPeer, after_t: float = 0.0) -> list[OverrideRecord]:
    return [o for o in list(peer.records.overrides) if o.t >= after_t and o.sysid == HELIXD_SYSID]


def undriven_untouched(values: tuple[int, ...], driven: set[int]) -> bool:
    return all(
        values[c - 1] == (LEAVE_LOW if c <= 8 else LEAVE_HIGH)
        for c in range(1, 19)
        if c not in driven
    )


async def test_rc_override_repeats_values_and_releases() -> None:
    cfg = actuation(ActuationBackend.RC_OVERRIDE, repeat_rate_hz=20.0, release_repeats=3)
    async with linked() as (ap, peer):
        sink = make_sink(cfg, VehicleConfig(output_clamp=0.9), ap)
        assert isinstance(sink, RcOverrideSink)
        t0 = time.monotonic()
        await sink.start()
        assert sink.held_channels == frozenset({1, 2, 3, 10})
        await until(lambda: time.monotonic() - t0 > 1.2, 3.0, "1.2 s of repeats")
        window = overrides(peer, t0 + 0.1)
        rate = (len(window) - 1) / (window[-1].t - window[0].t)
        assert rate >= 0.8 * 20.0, f"override repeat rate {rate:.1f} Hz"
        first = window[0].values
        assert [first[c - 1] for c in (1, 2, 3, 10)] == [1500] * 4  # neutral after start
        assert undriven_untouched(first, {1, 2, 3, 10})

        t_cmd = time.monotonic()
        sink.command([0.5, -0.5, 0.0, 1.0])  # 1.0 is clamped to output_clamp 0.9
        assert sink.last_pwm_us == (1750, 1250, 1500, 1950)
        await until(lambda: overrides(peer, t_cmd) != [], 1.0, "the command on the wire")
        sent = overrides(peer, t_cmd)[0]
        assert sent.t - t_cmd < 0.05  # sent at once, not at the next repeat
        assert [sent.values[c - 1] for c in (1, 2, 3, 10)] == [1750, 1250, 1500, 1950]
        assert undriven_untouched(sent.values, {1, 2, 3, 10})

        t_stop = time.monotonic()
        await sink.stop()
        assert time.monotonic() - t_stop < cfg.stop_timeout_s
        assert sink.held_channels == frozenset()
        await until(lambda: len(overrides(peer, t_stop)) >= 4, 1.0, "neutral + 3 releases")
        neutral, *releases = overrides(peer, t_stop)
        assert [neutral.values[c - 1] for c in (1, 2, 3, 10)] == [1500] * 4
        assert len(releases) == 3
        for r in releases:
            assert [r.values[c - 1] for c in (1, 2, 3)] == [RELEASE_LOW] * 3
            assert r.values[9] == RELEASE_HIGH
            assert undriven_untouched(r.values, {1, 2, 3, 10})
        t_after = time.monotonic()
        await stays(lambda: overrides(peer, t_after) == [], 0.4, "no overrides after stop")
        await sink.stop()  # idempotent: nothing more is sent
        assert overrides(peer, t_after) == []


class RecordingSender:
    """An OverrideSender that keeps (the run's clock, frame) of every send."""

    def __init__(self) -> None:
        self.sent: list[tuple[float, tuple[int, ...]]] = []
        self.changed = asyncio.Event()

    def send_rc_override(self, channels_us: Sequence[int]) -> None:
        self.sent.append((now_s(), tuple(channels_us)))
        self.changed.set()


def test_rc_override_repeats_only_in_the_gaps_between_commands() -> None:
    """Commands every 10 ms with a 10 Hz repeat: nothing but the commands is sent; once they
    stop, the latest frame is repeated one repeat period after the last command, then at the
    repeat rate (on the simulated clock: exactly)."""
    run_simulated(_repeats_only_in_the_gaps)


async def _repeats_only_in_the_gaps() -> None:
    cfg = actuation(ActuationBackend.RC_OVERRIDE, repeat_rate_hz=10.0)
    sender = RecordingSender()
    sink = RcOverrideSink(cfg, VehicleConfig(), sender)
    loop = asyncio.get_running_loop()
    await sink.start()
    commands_done = asyncio.Event()
    n_commands = 30

    def command(k: int) -> None:
        sink.command([0.01 * k, 0.0, 0.0, 0.0])
        if k + 1 < n_commands:
            loop.call_later(0.01, command, k + 1)
        else:
            commands_done.set()

    loop.call_soon(command, 0)
    await asyncio.wait_for(commands_done.wait(), 5.0)
    assert len(sender.sent) == 1 + n_commands  # the neutral at start, then each command once
    t_last, last_frame = sender.sent[-1]
    while len(sender.sent) < n_commands + 3:  # two repeats
        sender.changed.clear()
        await asyncio.wait_for(sender.changed.wait(), 2.0)
    (t_r1, f1), (t_r2, f2) = sender.sent[-2:]
    assert f1 == f2 == last_frame  # the latest frame, repeated
    assert t_r1 - t_last == pytest.approx(0.1)  # one repeat period after the last command
    assert t_r2 - t_r1 == pytest.approx(0.1)  # then at the repeat rate
    await sink.stop()


async def test_rc_override_stop_on_a_dead_link_does_not_raise() -> None:
    cfg = actuation(ActuationBackend.RC_OVERRIDE)
    async with linked() as (ap, peer):
        sink = make_sink(cfg, VehicleConfig(), ap)
        await sink.start()
        sink.command([0.3, 0.3, 0.3, 0.3])
        peer.stop()  # the autopilot is gone: sends now fail with ECONNREFUSED
        t0 = time.monotonic()
        await sink.stop()
        assert time.monotonic() - t0 < cfg.stop_timeout_s + 0.1
        assert sink.held_channels == frozenset()
        await sink.close()


async def test_servo_start_sends_neutral_first_and_sends_on_change() -> None:
    cfg = actuation(ActuationBackend.SERVO, channels=(1, 2, 3, 4))
    async with linked() as (ap, peer):
        peer.servo_out[0] = 1900  # latched by a previous, killed run
        sink = make_sink(cfg, VehicleConfig(), ap)
        assert isinstance(sink, ServoSink)
        t0 = time.monotonic()
        await sink.start()
        first = peer.records.commands_of(SET_SERVO, t0)
        assert [(int(c.params[0]), int(c.params[1])) for c in first] == [
            (1, 1500),
            (2, 1500),
            (3, 1500),
            (4, 1500),
        ]
        assert peer.servo_out[0] == 1500
        assert sink.held_channels == frozenset()

        t1 = time.monotonic()
        for _ in range(20):  # the control loop repeats the same command every tick
            sink.command([0.5, 0.0, 0.0, 0.0])
        await until(lambda: peer.servo_out[0] == 1750, 2.0, "channel 1 at 1750")
        await stays(
            lambda: len(peer.records.commands_of(SET_SERVO, t1)) == 1,
            0.3,
            "a single DO_SET_SERVO for an unchanged command",
        )
        assert sink.held_channels == frozenset({1})

        t2 = time.monotonic()
        await sink.stop()
        stops = peer.records.commands_of(SET_SERVO, t2)
        assert [(int(c.params[0]), int(c.params[1])) for c in stops] == [(1, 1500)]
        assert peer.servo_out[0] == 1500 and sink.held_channels == frozenset()


async def test_servo_values_are_refreshed_because_an_ack_is_no_proof() -> None:
    """helixd-guard may have held an output while a DO_SET_SERVO came in (ACCEPTED, dropped):
    each channel is sent again once its last send is actuation.servo_refresh_s old."""
    cfg = actuation(ActuationBackend.SERVO, channels=(1, 2, 3, 4), servo_refresh_s=0.2)
    async with linked() as (ap, peer):
        sink = make_sink(cfg, VehicleConfig(), ap)
        await sink.start()
        sink.command([0.5, 0.0, 0.0, 0.0])
        await until(lambda: peer.servo_out[0] == 1750, 2.0, "channel 1 at 1750")
        peer.servo_out[0] = 1500  # the guard's trim stayed on the output after an episode
        t0 = time.monotonic()
        await until(lambda: peer.servo_out[0] == 1750, 1.0, "channel 1 restored by a refresh")
        restored_s = time.monotonic() - t0
        assert restored_s <= 0.2 + 0.15
        t1 = time.monotonic()
        await until(lambda: time.monotonic() - t1 >= 0.5, 1.0, "0.5 s of refreshes")
        sent = peer.records.commands_of(SET_SERVO, t1)
        for ch in (1, 2, 3, 4):  # every channel, about every 0.2 s, at its desired value
            values = [int(c.params[1]) for c in sent if int(c.params[0]) == ch]
            assert 2 <= len(values) <= 4, (ch, values)
            assert set(values) == {1750 if ch == 1 else 1500}
        await sink.stop()


async def test_servo_refusal_at_start_is_a_typed_error() -> None:
    cfg = actuation(ActuationBackend.SERVO, channels=(1, 2, 3, 4))
    async with linked() as (ap, peer):
        peer.params["SERVO3_FUNCTION"] = 73.0  # ThrottleLeft: ArduPilot refuses DO_SET_SERVO
        sink = make_sink(cfg, VehicleConfig(), ap)
        with pytest.raises(ServoCommandRefused) as info:
            await sink.start()
        assert isinstance(info.value, CommandError)
        assert info.value.channel == 3 and info.value.result_name == "FAILED"
        assert "SERVO3_FUNCTION" in str(info.value)
        await sink.stop()


async def test_servo_refusal_while_driving_is_surfaced() -> None:
    cfg = actuation(ActuationBackend.SERVO, channels=(1, 2, 3, 4))
    async with linked() as (ap, peer):
        sink = make_sink(cfg, VehicleConfig(), ap)
        assert isinstance(sink, ServoSink)
        await sink.start()
        peer.params["SERVO2_FUNCTION"] = 73.0
        sink.command([0.0, 0.5, 0.0, 0.0])
        await until(lambda: sink.fault is not None, 2.0, "the refusal")
        assert sink.fault is not None and sink.fault.channel == 2
        with pytest.raises(ServoCommandRefused):
            sink.command([0.0, 0.5, 0.0, 0.0])
        await sink.stop()


async def test_dry_run_logs_and_sends_nothing() -> None:
    cfg = actuation(ActuationBackend.DRY_RUN)
    sink = make_sink(cfg, VehicleConfig(), None)
    assert isinstance(sink, DryRunSink)
    with capture_logs() as logs:
        await sink.start()
        sink.command([0.2, 0.0, -0.2, 0.0])
        await sink.stop()
    events = [e["event"] for e in logs]
    assert events == ["dry_run_start", "dry_run_command", "dry_run_stop"]
    assert logs[1]["would_send"] == {"ch1": 1600, "ch2": 1500, "ch3": 1400, "ch10": 1500}
    assert sink.held_channels == frozenset()
    with pytest.raises(ValueError, match="needs an autopilot"):
        make_sink(actuation(ActuationBackend.RC_OVERRIDE), VehicleConfig(), None)
