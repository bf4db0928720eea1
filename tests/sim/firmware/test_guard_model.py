"""helixd-guard's pure mirror (helixd/sim/firmware/guard_model.py) and its agreement with the
Lua script."""

from __future__ import annotations

import re

import pytest

from helixd.mav import guard_script as mg
from helixd.sim.firmware import guard_model as g
from tests.support.paths import REPO_ROOT

LUA = REPO_ROOT / "helixd" / "mav" / "scripts" / "helixd-guard.lua"
MANUAL = 0


def run(
    guard: g.HelixdGuard,
    t0_s: float,
    t1_s: float,
    *,
    armed: bool = True,
    last_s: float | None,
    mode: int = MANUAL,
) -> list[tuple[float, g.GuardAction]]:
    """Step every UPDATE_PERIOD_MS from t0 (inclusive) to t1 (exclusive)."""
    out: list[tuple[float, g.GuardAction]] = []
    k = 0
    while True:
        t = t0_s + k * g.UPDATE_PERIOD_MS / 1000.0
        if t >= t1_s - 1e-9:
            return out
        out.append((t, guard.step(t, armed, last_s, mode)))
        k += 1


def test_start_text() -> None:
    assert g.start_text(mg.GuardParams()) == (
        g.SEVERITY_INFO,
        "helixd-guard: v1 on, outputs 1 2 3 4, 500 ms",
    )
    off = mg.GuardParams(enable=0, chan1=0, chan2=0, chan3=0, chan4=0, timeout_s=0.75)
    assert g.start_text(off)[1] == "helixd-guard: v1 off, outputs none, 750 ms"


# --- the state machine -----------------------------------------------------------------------


def test_disarmed_never_acts() -> None:
    guard = g.HelixdGuard()
    for _, action in run(guard, 0.0, 5.0, armed=False, last_s=None):
        assert action == g.GuardAction()
    for _, action in run(guard, 5.0, 10.0, armed=False, last_s=1.0):
        assert action == g.GuardAction()


def test_timeout_boundary_is_strict() -> None:
    guard = g.HelixdGuard()
    assert guard.step(10.5, True, 10.0, MANUAL) == g.GuardAction()  # 500 ms: not yet
    action = guard.step(10.501, True, 10.0, MANUAL)  # 501 ms: silent
    assert action.guarding
    assert action.hold_trim == (1, 2, 3, 4)


def test_engage_once_then_renew_without_repeats() -> None:
    guard = g.HelixdGuard(mg.GuardParams(chan1=3, chan2=4, chan3=1, chan4=2))
    steps = run(guard, 1.0, 3.0, last_s=0.4)
    first = steps[0][1]
    assert first.guarding
    assert first.hold_trim == (3, 4, 1, 2)
    assert first.hold_ms == g.OVERRIDE_MS == 100
    assert first.request_hold
    assert first.texts == ((g.SEVERITY_CRITICAL, "helixd-guard: no heartbeat 500 ms, trim + HOLD"),)
    for _, action in steps[1:]:
        assert action.hold_trim == (3, 4, 1, 2)  # renewed every step
        assert action.hold_ms == 100
        assert not action.request_hold  # HOLD asked once per episode
        assert action.texts == ()
    # the renewal outlasts the update period, so one late step does not drop the outputs
    assert g.OVERRIDE_MS > g.UPDATE_PERIOD_MS


def test_already_in_hold_is_not_asked_again() -> None:
    guard = g.HelixdGuard()
    action = guard.step(2.0, True, 1.0, g.MODE_HOLD)
    assert action.guarding
    assert not action.request_hold
    assert action.texts[0][1].startswith(g.TEXT_PREFIX)


def test_refused_hold_and_unchanged_mode_is_no_takeover() -> None:
    """HOLD asked but not granted (no hold_granted()): staying in the mode found at engagement
    is no human taking over, the scrolls stay at trim."""
    guard = g.HelixdGuard()
    assert guard.step(2.0, True, 1.0, MANUAL).request_hold
    for _, action in run(guard, 2.05, 4.0, last_s=1.0, mode=MANUAL):
        assert not action.request_hold
        assert action.hold_trim == (1, 2, 3, 4)
        assert action.release_rc == ()


AUTO = 10
RTL = 11


def takeover(mode: int) -> g.GuardAction:
    return g.GuardAction(
        texts=((g.SEVERITY_NOTICE, g.takeover_text(mode)),), release_rc=(1, 2, 3, 4)
    )


def test_leaving_granted_hold_releases_until_helixd_is_heard_again() -> None:
    guard = g.HelixdGuard()
    first = guard.step(2.0, True, 1.0, AUTO)
    assert first.request_hold
    guard.hold_granted()  # vehicle:set_mode(HOLD) returned true
    assert guard.step(2.05, True, 1.0, g.MODE_HOLD).hold_trim == (1, 2, 3, 4)
    # the pilot flips the mode switch to MANUAL: released at once, said once
    assert guard.step(2.1, True, 1.0, MANUAL) == takeover(MANUAL)
    assert g.takeover_text(MANUAL) == "helixd-guard: mode 0, pilot in charge, released"
    # hands off, whatever the mode, however long helixd stays silent
    for mode in (MANUAL, g.MODE_HOLD, AUTO):
        for _, action in run(guard, 2.15, 20.0, last_s=1.0, mode=mode):
            assert action == g.GuardAction()
    # helixd heard again (newer than the release) → watching again; its next silence engages
    assert guard.step(20.0, True, 19.99, MANUAL) == g.GuardAction()
    again = guard.step(20.6, True, 19.99, MANUAL)
    assert again.guarding and again.request_hold
    assert again.texts == ((g.SEVERITY_CRITICAL, g.silent_text(500)),)


def test_granted_hold_then_other_mode_before_it_was_seen_releases() -> None:
    """Rapid switch: HOLD granted at engagement, the pilot is out of it again before the next
    update ever saw HOLD: still a takeover (base_mode is HOLD)."""
    guard = g.HelixdGuard()
    assert guard.step(2.0, True, 1.0, AUTO).request_hold
    guard.hold_granted()
    assert guard.step(2.05, True, 1.0, AUTO) == takeover(AUTO)


def test_already_hold_at_engagement_then_manual_releases() -> None:
    """helixd's own fallback (or a takeover to HOLD) left the vehicle in HOLD."""
    guard = g.HelixdGuard()
    first = guard.step(2.0, True, 1.0, g.MODE_HOLD)
    assert first.guarding and not first.request_hold
    assert guard.step(2.05, True, 1.0, g.MODE_HOLD).hold_trim == (1, 2, 3, 4)
    assert guard.step(2.1, True, 1.0, MANUAL) == takeover(MANUAL)


def test_refused_hold_then_hold_seen_then_leaving_releases() -> None:
    guard = g.HelixdGuard()
    assert guard.step(2.0, True, 1.0, AUTO).request_hold  # refused: no hold_granted()
    assert guard.step(2.05, True, 1.0, AUTO).hold_trim == (1, 2, 3, 4)
    assert guard.step(2.1, True, 1.0, g.MODE_HOLD).hold_trim == (1, 2, 3, 4)  # HOLD observed
    assert guard.step(2.15, True, 1.0, AUTO) == takeover(AUTO)  # back to AUTO: a human


def test_refused_hold_then_another_mode_releases() -> None:
    guard = g.HelixdGuard()
    assert guard.step(2.0, True, 1.0, AUTO).request_hold  # refused
    assert guard.step(2.05, True, 1.0, RTL) == takeover(RTL)


def test_takeover_release_is_reset_by_disarm_and_by_disable() -> None:
    guard = g.HelixdGuard()
    guard.step(2.0, True, 1.0, g.MODE_HOLD)
    assert guard.step(2.05, True, 1.0, MANUAL) == takeover(MANUAL)
    assert guard.step(3.0, False, 1.0, MANUAL) == g.GuardAction()  # disarm: silent reset
    again = guard.step(4.0, True, 1.0, MANUAL)  # re-armed, helixd still silent: guards
    assert again.guarding and again.request_hold
    guard.hold_granted()
    assert guard.step(4.05, True, 1.0, MANUAL) == takeover(MANUAL)
    guard.params = mg.GuardParams(enable=0)
    assert guard.step(4.1, True, 1.0, MANUAL) == g.GuardAction()
    guard.params = mg.GuardParams()
    assert guard.step(4.15, True, 1.0, MANUAL).guarding  # re-enabled: watching again


def test_takeover_when_never_heard_stays_released_until_first_heartbeat() -> None:
    guard = g.HelixdGuard()
    assert guard.step(0.5, True, None, g.MODE_HOLD).guarding
    assert guard.step(0.55, True, None, MANUAL) == takeover(MANUAL)
    for _, action in run(guard, 0.6, 5.0, last_s=None):
        assert action == g.GuardAction()
    assert guard.step(5.0, True, 4.99, MANUAL) == g.GuardAction()
    assert guard.step(5.6, True, 4.99, MANUAL).guarding


def test_heartbeat_older_than_release_does_not_rearm() -> None:
    guard = g.HelixdGuard()
    guard.step(2.0, True, 1.0, g.MODE_HOLD)
    assert guard.step(2.05, True, 1.0, MANUAL) == takeover(MANUAL)
    assert guard.step(2.1, True, 2.05, MANUAL) == g.GuardAction()  # same ms as the release
    assert guard.step(2.15, True, 2.05, MANUAL) == g.GuardAction()
    assert not guard.guarding and guard.released_ms == 2050


@pytest.mark.parametrize("last_s", [None, 0.0, 0.0004])
def test_never_seen_and_armed_guards(last_s: float | None) -> None:
    """gcs:last_seen() is 0 until helixd's first HEARTBEAT: armed without helixd → trim."""
    guard = g.HelixdGuard()
    action = guard.step(0.01, True, last_s, MANUAL)
    assert action.guarding
    assert action.hold_trim == (1, 2, 3, 4)
    assert action.request_hold
    assert action.texts == ((g.SEVERITY_CRITICAL, g.NEVER_SEEN_TEXT),)


def test_heartbeat_back_releases_once() -> None:
    guard = g.HelixdGuard()
    assert guard.step(3.0, True, 1.0, MANUAL).guarding
    back = guard.step(3.05, True, 3.04, g.MODE_HOLD)
    assert not back.guarding
    assert back.hold_trim == ()
    assert not back.request_hold
    assert back.texts == ((g.SEVERITY_NOTICE, g.BACK_TEXT),)
    for _, action in run(guard, 3.1, 4.0, last_s=3.9):
        assert action == g.GuardAction()


def test_disarm_releases_and_rearm_starts_a_new_episode() -> None:
    guard = g.HelixdGuard()
    assert guard.step(3.0, True, 1.0, MANUAL).request_hold
    off = guard.step(3.05, False, 1.0, g.MODE_HOLD)
    assert off.texts == ((g.SEVERITY_NOTICE, g.DISARMED_TEXT),)
    assert off.hold_trim == ()
    again = guard.step(4.0, True, 1.0, MANUAL)
    assert again.request_hold
    assert again.hold_trim == (1, 2, 3, 4)
    assert again.texts[0][0] == g.SEVERITY_CRITICAL


def test_disable_releases_and_reenable_guards() -> None:
    guard = g.HelixdGuard()
    assert guard.step(3.0, True, 1.0, MANUAL).guarding
    guard.params = mg.GuardParams(enable=0)
    off = guard.step(3.05, True, 1.0, MANUAL)
    assert off.texts == ((g.SEVERITY_NOTICE, g.DISABLED_TEXT),)
    assert not off.guarding
    assert guard.step(3.1, True, 1.0, MANUAL) == g.GuardAction()
    guard.params = mg.GuardParams()
    assert guard.step(3.15, True, 1.0, MANUAL).request_hold


def test_params_read_every_step() -> None:
    guard = g.HelixdGuard()
    assert guard.step(1.4, True, 1.0, MANUAL) == g.GuardAction()  # 400 ms < 500 ms
    guard.params = mg.GuardParams(timeout_s=0.3, chan2=0)
    action = guard.step(1.45, True, 1.0, MANUAL)
    assert action.hold_trim == (1, 3, 4)
    assert action.texts[0][1] == "helixd-guard: no heartbeat 300 ms, trim + HOLD"


def test_timeline_kill_latency_and_heartbeat_rate() -> None:
    """5 Hz heartbeats never trip the 0.5 s guard; 1 Hz (helixd's default) does; after the
    last heartbeat the guard engages within one update period of the timeout."""
    guard = g.HelixdGuard()
    for k in range(1, 50):  # 10 s at 5 Hz (millis() 0 would mean "never seen")
        last = k * 0.2
        for _, action in run(guard, last, last + 0.2, last_s=last):
            assert not action.guarding
    slow = g.HelixdGuard()
    assert any(a.guarding for _, a in run(slow, 1.0, 2.0, last_s=1.0))

    killed = g.HelixdGuard()
    last_hb = 7.2
    engaged = [t for t, a in run(killed, 7.2, 9.0, last_s=last_hb) if a.texts]
    assert len(engaged) == 1
    assert 0.5 < engaged[0] - last_hb <= 0.5 + g.UPDATE_PERIOD_MS / 1000.0 + 1e-9


# --- the Lua script says the same ------------------------------------------------------------


def lua_source() -> str:
    return LUA.read_text(encoding="utf-8")


@pytest.mark.parametrize(
    ("lua_name", "value"),
    [
        ("PERIOD_MS", g.UPDATE_PERIOD_MS),
        ("OVERRIDE_MS", g.OVERRIDE_MS),
        ("MODE_HOLD", g.MODE_HOLD),
    ],
)
def test_lua_constants_match(lua_name: str, value: int) -> None:
    m = re.search(rf"^local {lua_name} = (\d+)", lua_source(), re.MULTILINE)
    assert m is not None, lua_name
    assert int(m.group(1)) == value


@pytest.mark.parametrize(
    ("severity", "text"),
    [
        ("CRITICAL", g.NEVER_SEEN_TEXT),
        ("WARNING", g.HOLD_REFUSED_TEXT),
        ("NOTICE", g.BACK_TEXT),
        ("NOTICE", g.DISARMED_TEXT),
        ("NOTICE", g.DISABLED_TEXT),
    ],
)
def test_lua_texts_match(severity: str, text: str) -> None:
    assert f'gcs:send_text(MAV_SEVERITY.{severity}, "{text}")' in lua_source()


def test_lua_format_texts_match() -> None:
    src = lua_source()
    assert '"helixd-guard: no heartbeat %d ms, trim + HOLD", tmo' in src
    assert g.silent_text(500) == "helixd-guard: no heartbeat 500 ms, trim + HOLD"
    assert '"helixd-guard: v%d %s, outputs %s, %d ms"' in src
    assert '"helixd-guard: mode %d, pilot in charge, released", mode' in src
    for text in (g.NEVER_SEEN_TEXT, g.silent_text(10_000), g.BACK_TEXT, g.takeover_text(255)):
        assert len(text) <= 50  # one STATUSTEXT, no chunking


def test_lua_takeover_logic_present() -> None:
    """The mirror's takeover transitions, as the Lua spells them."""
    src = lua_source()
    for line in (
        "base_mode = mode",
        "if vehicle:set_mode(MODE_HOLD) then",
        "elseif mode == MODE_HOLD then",
        "elseif mode ~= base_mode then",
        "released_ms = now_ms",
        "(seen_ms - released_ms):toint() > 0",
        "ch:set_override(0)",
    ):
        assert line in src, line
