"""helixd against real ArduPilot Rover SITL (opt-in: ``HELIXD_SITL_BIN``).

Every test starts its own ``ardurover --model rover-skid`` (fixture ``sitl``) and runs the real
CLI, ``python -m helixd run --connect tcp:127.0.0.1:5760+10·I --mission square.yaml``, with
both actuation backends. Assertions are made on what ArduPilot reports on a second link
(SERVO_OUTPUT_RAW, HEARTBEAT, LOCAL_POSITION_NED), not only on what helixd says.

* the ROLL-mode 10 m square completes (exit 0, summary.json completed) and the rover really
  drove a counter-clockwise square back to its start;
* pilot takeover: the pilot switches to HOLD from another link mid-mission → exit 5, outputs 1
  and 3 back at trim; helixd-guard then engages (helixd silent, armed); the pilot switches to
  MANUAL (second link): the guard says "mode 0, pilot in charge, released" and lets go,
  HXG_ENABLE stays 1. RC override: the pilot's radio drives the passthrough outputs at once and
  keeps them; servo: the function-0 outputs keep the trim;
* ``kill -9`` of helixd mid-mission, with the real helixd-guard.lua running in ardurover: the
  outputs are watched for ≥ 5 s and reported; both backends: outputs 1..4 at trim within
  HXG_TIMEOUT + 0.3 s of the kill and HOLD, kept until the end (past RC_OVERRIDE_TIME);
* ``helixd autopilot install-guard`` over ArduPilot's own MAVLink FTP: the file lands in
  SITL's ``scripts/`` byte for byte.
"""

from __future__ import annotations

import json
import math
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import pytest

from helixd.base.exitcodes import ExitCode
from helixd.mav.guard_script import PARAM_DEFAULTS, VERSION, script_bytes
from helixd.recorder.track import TrackPoint
from tests.support.skid_setup import first_step_t_s, square_metrics

if TYPE_CHECKING:
    from tests.sitl.conftest import DaemonRun, MavClient, ServoSample, SitlVehicle

pytestmark = [pytest.mark.sitl, pytest.mark.timeout(1200)]

RC_OVERRIDE = "rc_override"
SERVO = "servo"
BACKENDS = (RC_OVERRIDE, SERVO)

NEUTRAL_US = 1500
TOLERANCE_US = 5
DEFLECTED_US = 10  # a held output further than this from 1500 shows the scrolls were driving
MODE_HOLD = 4
MODE_MANUAL = 0
GUARD_ENGAGED_TEXT = "helixd-guard: no heartbeat"
GUARD_RELEASED_TEXT = "helixd-guard: mode 0, pilot in charge, released"
POST_RELEASE_WATCH_S = 7.0  # past RC_OVERRIDE_TIME (3 s) and the GCS failsafe (5 s)
MAV_RESULT_ACCEPTED = 0
RC_OVERRIDE_TIME_S = 3.0  # helix-skid.parm
GUARD_TIMEOUT_S = PARAM_DEFAULTS["HXG_TIMEOUT"]  # helixd-guard's default (0.5 s)
GUARD_SLACK_S = 0.3  # its 50 ms period, the observer's 20 Hz samples, SITL's scheduling

# Wall-clock bounds (s); the mission itself is bounded in simulated seconds.
SETUP_WALL_S = 180.0  # helixd connect → preflight → arm on a freshly booted SITL
MISSION_SIM_S = 300.0  # the square takes ~90 s of simulated time at 0.6 m/s
DRIVING_TIMEOUT_S = 240.0
TAKEOVER_EXIT_S = 30.0
SECURED_WALL_S = 2.0  # mode switch → outputs neutral (the 0.5 s fall-back bound + link latency)
STICK_FOLLOW_S = 10.0
KILL_WAIT_S = 10.0
OBSERVE_WALL_S = 5.0  # watch the outputs at least this long after kill -9 …
# … and, in simulated time, past RC_OVERRIDE_TIME and the GCS failsafe's action
# (FS_GCS_TIMEOUT 5 s + FS_TIMEOUT 1.5 s, Rover defaults) plus a margin.
OBSERVE_SIM_S = 8.0
SETTLE_S = 0.2  # simulated s after the kill for the last in-flight command to land (< the guard)

# The square (config/missions/square.yaml): 10 m legs, counter-clockwise, back to the start.
SQUARE_FAR_CORNER_M = 10.0 * math.sqrt(2.0)
ARRIVAL_TOLERANCE_M = 1.0
FIRST_LEG_PROBE_M = 5.0


def mission_timeout_s(speedup: float) -> float:
    return SETUP_WALL_S + MISSION_SIM_S / speedup


def near(pwm: Sequence[int] | None, out1_us: int, out3_us: int) -> bool:
    """Outputs 1 and 3 (the skid model's left and right motors) at the given PWM."""
    return (
        pwm is not None
        and abs(pwm[0] - out1_us) <= TOLERANCE_US
        and abs(pwm[2] - out3_us) <= TOLERANCE_US
    )


def read_summary(run_dir: Path) -> dict[str, Any]:
    data: dict[str, Any] = json.loads((run_dir / "summary.json").read_text(encoding="utf-8"))
    return data


def prepare(sitl: SitlVehicle, backend: str) -> None:
    if backend == SERVO:
        sitl.use_servo_outputs()


# ---------------------------------------------------------------------------------------------
# Pure analysis of what the autopilot reported


@dataclass(frozen=True, slots=True)
class TrackShape:
    max_distance_m: float  # farthest point from the start
    final_distance_m: float  # last point to the start
    left_turn_sin: float  # sin of the angle first leg → farthest point; > 0: to the left (CCW)


def track_shape(
    track_ne_m: Sequence[tuple[float, float]], start_ne_m: tuple[float, float]
) -> TrackShape:
    """Shape of a driven track from LOCAL_POSITION_NED (north, east) samples."""
    rel = [(n - start_ne_m[0], e - start_ne_m[1]) for n, e in track_ne_m]
    if not rel:
        return TrackShape(0.0, math.nan, math.nan)
    dist = [math.hypot(n, e) for n, e in rel]
    far = rel[dist.index(max(dist))]
    leg = next((p for p, d in zip(rel, dist, strict=True) if d >= FIRST_LEG_PROBE_M), None)
    sin = math.nan
    if leg is not None and max(dist) > 0.0:
        # In ENU (x east, y north) a positive z cross product is a counter-clockwise turn.
        cross = leg[1] * far[0] - leg[0] * far[1]
        sin = cross / (math.hypot(*leg) * math.hypot(*far))
    return TrackShape(max(dist), dist[-1], sin)


@dataclass(frozen=True, slots=True)
class KillReport:
    kill_t_boot_s: float  # last SERVO_OUTPUT_RAW before SIGKILL (simulated time)
    held_pwm: tuple[int, int, int, int] | None  # outputs 1..4 once in-flight commands landed
    first_change_s: float | None  # since the kill: outputs 1/3 first left the held value
    neutral_from_s: float | None  # since the kill: outputs 1/3 at 1500 from here to the end
    trim_from_s: float | None  # since the kill: outputs 1..4 at 1500 from here to the end
    final_pwm: tuple[int, int, int, int] | None
    observed_s: float  # simulated seconds watched after the kill
    changes: tuple[tuple[float, tuple[int, int, int, int]], ...]  # (s since kill, outputs)


def analyse_after_kill(samples: Sequence[ServoSample], kill_t_boot_s: float) -> KillReport:
    after = [s for s in samples if s.t_boot_s >= kill_t_boot_s]
    if not after:
        return KillReport(kill_t_boot_s, None, None, None, None, None, 0.0, ())
    changes: list[tuple[float, tuple[int, int, int, int]]] = []
    for s in after:
        if not changes or not near(s.pwm_us, changes[-1][1][0], changes[-1][1][2]):
            changes.append((s.t_boot_s - kill_t_boot_s, s.pwm_us))
    settled = [s for s in after if s.t_boot_s >= kill_t_boot_s + SETTLE_S]
    held = settled[0].pwm_us if settled else None
    first_change = None
    if held is not None:
        first_change = next(
            (s.t_boot_s - kill_t_boot_s for s in settled if not near(s.pwm_us, held[0], held[2])),
            None,
        )
    neutral_from = None
    for s in reversed(after):
        if not near(s.pwm_us, NEUTRAL_US, NEUTRAL_US):
            break
        neutral_from = s.t_boot_s - kill_t_boot_s
    trim_from = None
    for s in reversed(after):
        if not all_trim(s.pwm_us):
            break
        trim_from = s.t_boot_s - kill_t_boot_s
    return KillReport(
        kill_t_boot_s=kill_t_boot_s,
        held_pwm=held,
        first_change_s=first_change,
        neutral_from_s=neutral_from,
        trim_from_s=trim_from,
        final_pwm=after[-1].pwm_us,
        observed_s=after[-1].t_boot_s - kill_t_boot_s,
        changes=tuple(changes),
    )


def all_trim(pwm: Sequence[int] | None) -> bool:
    """Outputs 1..4 (every output helixd-guard holds here) at 1500."""
    return pwm is not None and all(abs(v - NEUTRAL_US) <= TOLERANCE_US for v in pwm[:4])


def describe_kill(backend: str, r: KillReport, extra: str) -> str:
    lines = [f"kill -9 of helixd mid-mission ({backend} backend), outputs 1..4 as ArduPilot saw:"]
    lines += [f"  +{t:6.2f} s  {pwm}" for t, pwm in r.changes]
    lines.append(
        f"  held {r.held_pwm}; first change after {_s(r.first_change_s)}; neutral from "
        f"{_s(r.neutral_from_s)}; outputs 1-4 at trim from {_s(r.trim_from_s)}; final "
        f"{r.final_pwm}; watched {r.observed_s:.1f} s (simulated)"
    )
    lines.append(f"  {extra}")
    return "\n".join(lines)


def _s(seconds: float | None) -> str:
    return "never" if seconds is None else f"+{seconds:.2f} s"


def deflected(pwm: Sequence[int] | None) -> bool:
    return pwm is not None and max(abs(pwm[0] - NEUTRAL_US), abs(pwm[2] - NEUTRAL_US)) > (
        DEFLECTED_US
    )


# ---------------------------------------------------------------------------------------------
# Tests


@pytest.mark.parametrize("backend", BACKENDS)
def test_roll_square_completes(
    sitl: SitlVehicle, launch_helixd: Callable[[str], DaemonRun], backend: str
) -> None:
    prepare(sitl, backend)
    daemon = launch_helixd(backend)
    code = daemon.wait_exit(mission_timeout_s(sitl.speedup))
    log = daemon.log_text()
    assert code == ExitCode.OK, log[-4000:]
    summary = read_summary(daemon.run_dir())
    print(
        f"{backend}: square completed={summary['completed']} in {summary['duration_s']:.1f} s, "
        f"path {summary['path_length_m']:.1f} m, cross-track rms {summary['cross_track_rms_m']} "
        f"max {summary['cross_track_max_m']} m, final error {summary['final_error_m']} m"
    )
    assert summary["completed"] is True
    assert summary["exit_code"] == 0
    assert summary["waypoints_reached"] == summary["waypoints_total"] == 4

    # The autopilot's side: HOLD, disarmed, both motors at trim.
    obs = sitl.obs
    obs.wait_until(
        lambda: (
            obs.mode() == MODE_HOLD
            and obs.armed() is False
            and near(obs.servo_pwm(), NEUTRAL_US, NEUTRAL_US)
        ),
        15.0,
        "HOLD, disarmed and outputs 1/3 at 1500 after the mission",
    )
    # …and the rover really drove the counter-clockwise square back to its start.
    track = [(p.north_m, p.east_m) for p in obs.positions_since(sitl.start_t_boot_s)]
    shape = track_shape(track, sitl.start_ne_m)
    print(f"{backend}: track as ArduPilot saw it: {shape}")
    samples = obs.positions_since(sitl.start_t_boot_s)
    track_points = [TrackPoint(p.t_boot_s, p.north_m, p.east_m) for p in samples]
    metrics = square_metrics(track_points, obs.yaw_at)
    # The planned polygon anchored where helixd took its start frame (its first control
    # step): ATTITUDE drifts by tenths of a degree while the rover waits, which alone moves
    # the RMS against the polygon anchored at the last rest sample by ~0.03 m.
    anchored = square_metrics(track_points, obs.yaw_at, first_step_t_s(daemon.run_dir()))
    print(
        f"{backend}: observer (LOCAL_POSITION_NED vs the planned polygon): "
        f"{'no metrics (no track or no ATTITUDE)' if metrics is None else metrics.line()}; "
        f"anchored at helixd's first step: "
        f"{'no metrics' if anchored is None else anchored.line()}"
    )
    assert shape.max_distance_m >= SQUARE_FAR_CORNER_M - 2 * ARRIVAL_TOLERANCE_M
    assert shape.final_distance_m <= 2 * ARRIVAL_TOLERANCE_M
    assert shape.left_turn_sin > 0.3  # ≈ sin 45° for the far corner of a left-hand square


def driving_square(
    sitl: SitlVehicle, launch_helixd: Callable[[str], DaemonRun], backend: str
) -> tuple[DaemonRun, MavClient]:
    """helixd flying the square with ``backend``, 2 m driven; (helixd, the observer)."""
    prepare(sitl, backend)
    daemon = launch_helixd(backend)
    sitl.wait_driving(daemon, min_distance_m=2.0, timeout_s=DRIVING_TIMEOUT_S)
    return daemon, sitl.obs


@pytest.mark.parametrize("backend", BACKENDS)
def test_pilot_takeover_by_mode_switch(
    sitl: SitlVehicle, launch_helixd: Callable[[str], DaemonRun], backend: str
) -> None:
    daemon, obs = driving_square(sitl, launch_helixd, backend)
    assert deflected(obs.servo_pwm())

    # The pilot flips to HOLD (from the second GCS link). HOLD alone does not stop an
    # RC-passthrough or function-0 output: helixd must notice and stop/release itself.
    assert obs.set_mode(MODE_HOLD) == MAV_RESULT_ACCEPTED
    switched = time.monotonic()
    obs.wait_until(
        lambda: near(obs.servo_pwm(), NEUTRAL_US, NEUTRAL_US),
        SECURED_WALL_S,
        "outputs 1 and 3 back at trim after the pilot switched to HOLD",
    )
    secured_s = time.monotonic() - switched
    code = daemon.wait_exit(TAKEOVER_EXIT_S)
    log = daemon.log_text()
    print(f"{backend}: takeover: outputs at trim {secured_s:.2f} s after the mode switch")
    assert code == ExitCode.OPERATOR_STOP, log[-4000:]
    assert "cause=pilot_takeover" in log
    assert obs.mode() == MODE_HOLD
    assert near(obs.servo_pwm(), NEUTRAL_US, NEUTRAL_US)

    # Still armed without helixd: helixd-guard engages (trim, already in HOLD). The pilot then
    # flips the mode out of HOLD (here MANUAL from the second link): a human took over, the
    # guard lets go and stays off while helixd is silent — HXG_ENABLE stays 1.
    assert obs.get_param("HXG_ENABLE") == 1.0
    obs.wait_until(
        lambda: any(t.startswith(GUARD_ENGAGED_TEXT) for t in obs.statustexts),
        GUARD_TIMEOUT_S + GUARD_SLACK_S + 2.0,
        "helixd-guard engaged after helixd's exit",
    )
    if backend == RC_OVERRIDE:
        sitl.pilot_rc({1: 1650, 3: 1350})  # sticks deflected; the guard's override holds trim
        time.sleep(0.5)
        assert near(obs.servo_pwm(), NEUTRAL_US, NEUTRAL_US)
    assert obs.set_mode(MODE_MANUAL) == MAV_RESULT_ACCEPTED
    to_manual = time.monotonic()
    obs.wait_until(
        lambda: GUARD_RELEASED_TEXT in obs.statustexts,
        GUARD_SLACK_S + 2.0,
        f"{GUARD_RELEASED_TEXT!r} after the switch to MANUAL",
    )
    released_s = time.monotonic() - to_manual
    if backend == RC_OVERRIDE:
        # RC passthrough: the guard cleared its own RC overrides, helixd had released its own:
        # the radio drives the outputs at once (not after RC_OVERRIDE_TIME)
        obs.wait_until(
            lambda: near(obs.servo_pwm(), 1650, 1350),
            STICK_FOLLOW_S,
            "outputs 1/3 following the pilot's radio after the switch to MANUAL",
        )
        follow_s = time.monotonic() - to_manual
        print(
            f"{backend}: MANUAL → guard released after {released_s:.2f} s, outputs follow the "
            f"radio after {follow_s:.2f} s (wall)"
        )
        assert follow_s < RC_OVERRIDE_TIME_S
        sitl.pilot_rc({1: 1600, 3: 1400})
        obs.wait_until(
            lambda: near(obs.servo_pwm(), 1600, 1400),
            STICK_FOLLOW_S,
            "outputs 1/3 following the sticks again",
        )
        # the radio keeps them past RC_OVERRIDE_TIME and the GCS failsafe (which may switch to
        # HOLD: no guard episode, and HOLD does not stop a passthrough output)
        time.sleep(POST_RELEASE_WATCH_S)
        assert near(obs.servo_pwm(), 1600, 1400), obs.servo_pwm()
        sitl.pilot_rc({1: NEUTRAL_US, 3: NEUTRAL_US})
        obs.wait_until(
            lambda: near(obs.servo_pwm(), NEUTRAL_US, NEUTRAL_US),
            STICK_FOLLOW_S,
            "outputs back at trim with the sticks centred",
        )
    else:
        # function 0: no radio input feeds it; ArduPilot leaves the guard's last value (trim)
        # on the output when the override times out
        time.sleep(POST_RELEASE_WATCH_S)
        pwm = obs.servo_pwm()
        print(
            f"{backend}: MANUAL → guard released after {released_s:.2f} s; outputs "
            f"{None if pwm is None else pwm[:4]} {POST_RELEASE_WATCH_S:.0f} s later"
        )
        assert pwm is not None and all(abs(v - NEUTRAL_US) <= TOLERANCE_US for v in pwm[:4])
    assert obs.armed() is True
    assert sum(t.startswith("helixd-guard: mode ") for t in obs.statustexts) == 1
    print(f"{backend}: STATUSTEXT {obs.statustexts[-5:]}; mode now {obs.mode()}")


@pytest.mark.parametrize("backend", BACKENDS)
def test_kill_9_mid_mission_reports_outputs(
    sitl: SitlVehicle, launch_helixd: Callable[[str], DaemonRun], backend: str
) -> None:
    daemon, obs = driving_square(sitl, launch_helixd, backend)
    last = obs.last_servo()
    assert last is not None
    killed_wall = time.monotonic()
    daemon.proc.send_signal(signal.SIGKILL)
    assert daemon.wait_exit(KILL_WAIT_S) == -signal.SIGKILL

    sim_end = last.t_boot_s + OBSERVE_SIM_S

    def watched_enough() -> bool:
        latest = obs.last_servo()
        return (
            latest is not None
            and latest.t_boot_s >= sim_end
            and time.monotonic() - killed_wall >= OBSERVE_WALL_S
        )

    obs.wait_until(
        watched_enough,
        OBSERVE_WALL_S + OBSERVE_SIM_S / sitl.speedup + 30.0,
        f"≥ {OBSERVE_WALL_S} s (wall) and {OBSERVE_SIM_S} s (simulated) of outputs after kill -9",
    )
    report = analyse_after_kill(obs.servo_since(last.t_boot_s), last.t_boot_s)
    modes = [
        f"{mode} at {wall - killed_wall:+.2f} s (wall)"
        for wall, mode in obs.mode_changes
        if wall >= killed_wall
    ]
    holds = [w - killed_wall for w, mode in obs.mode_changes if w >= killed_wall and mode == 4]
    hold_wall_s = holds[0] if holds else None
    heartbeat = (
        "not seen on the observer link"
        if obs.helixd_heartbeat_wall_s is None
        else f"{killed_wall - obs.helixd_heartbeat_wall_s:.2f} s before the kill"
    )
    print(
        describe_kill(
            backend,
            report,
            f"mode changes after the kill: {modes or 'none'}; now mode {obs.mode()} armed "
            f"{obs.armed()}; helixd's last HEARTBEAT {heartbeat}; "
            f"STATUSTEXT {obs.statustexts[-4:]}",
        )
    )

    assert deflected(report.held_pwm), "the scrolls were not driving when helixd was killed"
    assert report.first_change_s is not None and report.first_change_s > SETTLE_S
    # helixd-guard (the real Lua, running in ardurover) for both backends: HXG_TIMEOUT after
    # helixd's last message it holds outputs 1..4 at trim and asks HOLD; held to the end,
    # past RC_OVERRIDE_TIME and the GCS failsafe's time.
    print(
        f"kill -9 ({backend}, helixd-guard v{VERSION}): outputs 1-4 at trim from "
        f"{_s(report.trim_from_s)} (autopilot time), HOLD at "
        f"{'never' if hold_wall_s is None else f'+{hold_wall_s:.2f} s'} (wall) after the kill"
    )
    assert report.trim_from_s is not None
    assert report.trim_from_s <= GUARD_TIMEOUT_S + GUARD_SLACK_S
    assert hold_wall_s is not None and hold_wall_s <= GUARD_TIMEOUT_S + GUARD_SLACK_S
    assert obs.mode() == MODE_HOLD and obs.armed() is True
    assert any(t.startswith("helixd-guard: no heartbeat 500 ms") for t in obs.statustexts)


def test_install_guard_over_ardupilots_mavftp(bare_sitl: SitlVehicle, tmp_path: Path) -> None:
    """``helixd autopilot install-guard`` against ArduPilot's GCS_FTP: the scripts directory
    found by listing (SITL: ./scripts, made by scripting at boot), the file written byte for
    byte with the autopilot's CRC32 checked, SCR_ENABLE already 1."""
    sitl = bare_sitl
    assert sitl.guard_version() is None  # nothing runs yet
    assert (sitl.workdir / "scripts").is_dir()  # AP_Scripting made SCRIPTING_DIRECTORY
    res = subprocess.run(
        [sys.executable, "-m", "helixd", "autopilot", "install-guard", "--connect",
         sitl.helixd_url],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )  # fmt: skip
    print(res.stdout + res.stderr[-2000:])
    assert res.returncode == 0, res.stderr[-3000:]
    assert (sitl.workdir / "scripts" / "helixd-guard.lua").read_bytes() == script_bytes()
    assert " scripts/helixd-guard.lua (" in res.stdout and "found on the autopilot" in res.stdout
    assert "SCR_ENABLE = 1 (already set)" in res.stdout
    assert "reboot the autopilot to load it" in res.stdout
