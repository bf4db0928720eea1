"""The Helix itself on real ArduPilot SITL: four scrolls, three motion modes (opt-in:
``HELIXD_SITL_BIN``).

ArduPilot Rover takes its physics from ``helixd plant`` (``--model JSON``): the plant the
built-in simulator steps (eq. 1, motor lag, terrain traction and pits) reads outputs 1–4 —
RCIN1..4 passthrough from ``config/ardupilot/helix.parm``, which the suite boots from — and
ArduPilot's EKF3 fuses its own simulated GPS and compass from the plant's motion. helixd flies
with its defaults (the thesis's geometry and gains, scroll n on RC channel n).

* ROLL, SCROLL and OMNI missions (square, hexagon, circle; hard ground and mud) complete:
  exit 0, every waypoint reached, outputs 1–4 back at trim; each prints its figures on the
  plant's true pose beside the same flight on the built-in simulator, and the difference (the
  simulator's truth gap) stays within what docs/measurements.md states;
* ``kill -9`` of helixd while it drives all four scrolls (SCROLL): helixd-guard, the real Lua
  in ardurover, puts outputs 1–4 at trim within its timeout and asks HOLD;
* the pond crossing over the pond's media map (the plant's ground by place): in fixed SCROLL
  it completes, in fixed ROLL helixd stops it in the water; with the map given to helixd the
  mode follows the medium (ROLL on the banks, SCROLL through mud and water, each change
  stopped and turned in place on the bank) and it completes beside the built-in simulator's
  twin flight with the same map and policy.
"""

from __future__ import annotations

import json
import signal
import subprocess
import time
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from helixd.base.exitcodes import ExitCode
from helixd.base.media import MediaMapNe, Medium
from helixd.files.media import read_media_map
from helixd.mav.guard_script import PARAM_DEFAULTS
from helixd.recorder.rows import read_flight_columns
from tests.sitl.conftest import (
    DAEMON_STOP_TIMEOUT_S,
    POND_HOME,
    DaemonRun,
    SitlVehicle,
    start_test_sitl,
)
from tests.support.daemon import spawn_daemon
from tests.support.helix_sitl import (
    MISSIONS,
    flown_metrics,
    fly_on_builtin_sim,
    gap_line,
    helix_sitl_config,
    truth_track,
)

POND_MEDIA = MISSIONS.parent / "maps" / "pond-media.geojson"

pytestmark = [pytest.mark.sitl, pytest.mark.timeout(1500)]

NEUTRAL_US = 1500
TOLERANCE_US = 5
MODE_HOLD = 4
MISSION_WALL_S = 600.0  # setup, arm and the slowest mission (SCROLL in mud) at speed-up 1
DRIVING_TIMEOUT_S = 240.0
GUARD_TIMEOUT_S = PARAM_DEFAULTS["HXG_TIMEOUT"]
GUARD_SLACK_S = 0.3  # the guard's 50 ms period, the observer's 20 Hz samples, scheduling
KILL_WAIT_S = 10.0
# The truth gap a flight may show (SITL − built-in simulator, both on the true pose):
# real ArduPilot adds its EKF's estimate (SITL's GPS and compass), the output pipeline's delay
# and its scheduler; measured gaps are in docs/measurements.md.
RMS_GAP_M = 0.05
TIME_RATIO = (0.90, 1.10)

# (mission, mode, terrain): each mode on hard ground, SCROLL and OMNI in mud too
FLIGHTS = [
    ("square", "roll", "hard"),
    ("square", "scroll", "hard"),
    ("square", "omni", "hard"),
    ("square", "scroll", "mud"),
    ("hexagon", "omni", "hard"),
    ("circle", "scroll", "mud"),
    ("hexagon", "omni", "mud"),
]


def helixd_config(url: str, media_map: Path | None = None) -> dict[str, Any]:
    """The suite's helixd.yaml; with ``media_map`` (``media.media_map``) the mode follows the
    medium: each stretch in its medium's mode, ``mode`` only where the map says nothing."""
    cfg = helix_sitl_config(url)
    if media_map is not None:
        cfg["media"] = {"media_map": str(media_map)}
    return cfg


def launch(
    tmp_path: Path,
    sitl: SitlVehicle,
    mission: Path,
    mode: str | None,
    media_map: Path | None = None,
) -> DaemonRun:
    """``helixd run`` against ``sitl``; ``mode`` None: the mission's own (with ``media_map``
    the mode follows the medium: ``--mode`` would set the media plan aside)."""
    cfg_path = tmp_path / "helixd-helix.yaml"
    cfg = helixd_config(sitl.helixd_url, media_map)
    cfg_path.write_text(yaml.safe_dump(cfg, sort_keys=False), encoding="utf-8")
    run_root = tmp_path / "runs"
    args = ["run", "--connect", sitl.helixd_url, "--mission", str(mission)]
    args += [] if mode is None else ["--mode", mode]
    args += ["--config", str(cfg_path), "--run-dir", str(run_root)]
    return spawn_daemon(args, cwd=tmp_path, run_root=run_root, stdin=subprocess.DEVNULL)


@pytest.fixture
def helixd_runs() -> Iterator[list[DaemonRun]]:
    runs: list[DaemonRun] = []
    yield runs
    for run in runs:
        run.stop(DAEMON_STOP_TIMEOUT_S)


def all_at(pwm: tuple[int, int, int, int] | None, target_us: int) -> bool:
    return pwm is not None and all(abs(p - target_us) <= TOLERANCE_US for p in pwm)


@pytest.mark.parametrize(
    ("mission", "mode", "helix_sitl"),
    FLIGHTS,
    ids=[f"{m}-{mode}-{t}" for m, mode, t in FLIGHTS],
    indirect=["helix_sitl"],
)
def test_helix_mission_on_real_ardupilot(
    helix_sitl: SitlVehicle,
    helixd_runs: list[DaemonRun],
    tmp_path: Path,
    mission: str,
    mode: str,
) -> None:
    sitl = helix_sitl
    assert sitl.plant is not None
    mission_path = MISSIONS / f"{mission}.yaml"
    daemon = launch(tmp_path, sitl, mission_path, mode)
    helixd_runs.append(daemon)
    code = daemon.wait_exit(MISSION_WALL_S)
    assert code == ExitCode.OK, daemon.log_text()[-4000:]
    run_dir = daemon.run_dir()
    summary = json.loads((run_dir / "summary.json").read_text(encoding="utf-8"))
    assert summary["completed"] is True
    assert summary["waypoints_reached"] == summary["waypoints_total"]
    obs = sitl.obs
    obs.wait_until(
        lambda: all_at(obs.servo_pwm(), NEUTRAL_US) and obs.armed() is False,
        15.0,
        "outputs 1-4 at 1500 and disarmed after the mission",
    )
    sitl.plant.stop()  # the truth file is complete
    sitl_metrics = flown_metrics(run_dir, truth_track(sitl.plant.truth_csv), mission_path)
    assert sitl_metrics is not None
    twin = fly_on_builtin_sim(
        tmp_path / "sim", mission_path, mode, sitl.plant.terrain, helix_sitl_config("unused")
    )
    assert twin.exit_code == ExitCode.OK
    assert twin.metrics is not None
    name = f"{mission} {mode} {sitl.plant.terrain}"
    print(gap_line(name, sitl_metrics, twin.metrics))
    print(
        f"{name}: helixd's own figures on SITL (EKF pose): rms {summary['cross_track_rms_m']} "
        f"max {summary['cross_track_max_m']} final {summary['final_error_m']} m, "
        f"{summary['duration_s']:.1f} s"
    )
    assert sitl_metrics.cross_track_rms_m - twin.metrics.cross_track_rms_m <= RMS_GAP_M
    ratio = sitl_metrics.elapsed_s / twin.metrics.elapsed_s
    assert TIME_RATIO[0] <= ratio <= TIME_RATIO[1], f"time ×{ratio:.2f}"


@pytest.mark.parametrize("helix_sitl", ["hard"], indirect=True)
def test_kill_9_while_scrolling_all_four_outputs_to_trim(
    helix_sitl: SitlVehicle, helixd_runs: list[DaemonRun], tmp_path: Path
) -> None:
    sitl = helix_sitl
    obs = sitl.obs
    daemon = launch(tmp_path, sitl, MISSIONS / "square.yaml", "scroll")
    helixd_runs.append(daemon)
    # driving in SCROLL: all four outputs away from trim
    obs.wait_until(
        lambda: (
            bool(obs.armed())
            and (pwm := obs.servo_pwm()) is not None
            and min(abs(p - NEUTRAL_US) for p in pwm) >= 30
            and (sitl.distance_from_start_m() or 0.0) >= 1.0
        ),
        DRIVING_TIMEOUT_S,
        "helixd scrolling (outputs 1-4 deflected, 1 m driven)",
        abort=daemon.ended,
    )
    last = obs.last_servo()
    assert last is not None
    killed_wall = time.monotonic()
    daemon.proc.send_signal(signal.SIGKILL)
    assert daemon.wait_exit(KILL_WAIT_S) == -signal.SIGKILL
    obs.wait_until(
        lambda: all_at(obs.servo_pwm(), NEUTRAL_US) and obs.mode() == MODE_HOLD,
        10.0,
        "outputs 1-4 at trim and HOLD after kill -9",
    )
    trimmed = next(s for s in obs.servo_since(last.t_boot_s) if all_at(s.pwm_us, NEUTRAL_US))
    holds = [w - killed_wall for w, mode in obs.mode_changes if w >= killed_wall and mode == 4]
    trim_after_s = trimmed.t_boot_s - last.t_boot_s
    print(
        f"kill -9 in SCROLL (Helix plant): outputs {last.pwm_us} → 1-4 at trim "
        f"{trim_after_s:.2f} s (autopilot time) after the last driven sample, HOLD "
        f"{holds[0] if holds else float('nan'):+.2f} s (wall) after the kill"
    )
    assert trim_after_s <= GUARD_TIMEOUT_S + GUARD_SLACK_S
    assert holds and holds[0] <= GUARD_TIMEOUT_S + GUARD_SLACK_S
    assert any(t.startswith("helixd-guard: no heartbeat") for t in obs.statustexts)
    # held: a second later still at trim
    held_until = obs.last_servo()
    obs.wait_until(
        lambda: (
            (s := obs.last_servo()) is not None
            and held_until is not None
            and s.t_boot_s >= held_until.t_boot_s + 1.0
        ),
        10.0,
        "a second more of outputs",
    )
    assert all(all_at(s.pwm_us, NEUTRAL_US) for s in obs.servo_since(trimmed.t_boot_s))


SCROLL_POWER_W = 100.0  # one scroll at full speed (tools/bench_amphibious.py's assumption)


def scroll_energy_j(c: Mapping[str, np.ndarray]) -> float:
    """Σ over the four scrolls of SCROLL_POWER_W · |commanded fraction of max rpm| · dt from
    flight.csv's scroll1..4, zero-order hold (the bench's figure, on the commands)."""
    t = c["t_boot_s"]
    load = sum(np.abs(np.nan_to_num(c[f"scroll{k}"])) for k in range(1, 5))
    return float(SCROLL_POWER_W * np.sum(load[:-1] * np.diff(t)))


@pytest.fixture
def pond_sitl(tmp_path: Path) -> Iterator[SitlVehicle]:
    """The Helix plant at the example pond: the media map config/maps/pond-media.geojson (a
    hard bank, a mud margin, the water), SITL's home where the map lies."""
    yield from start_test_sitl(
        tmp_path, guard=True, terrain="hard", media=POND_MEDIA, home=POND_HOME
    )


@pytest.mark.parametrize("mode", ["scroll", "roll"])
def test_pond_crossing_scrolls_through_the_water_and_roll_cannot(
    pond_sitl: SitlVehicle, helixd_runs: list[DaemonRun], tmp_path: Path, mode: str
) -> None:
    """config/missions/pond-crossing.yaml from the bank, across the water and back to the bank:
    in SCROLL it completes on real ArduPilot as on the built-in simulator with the same map; in
    ROLL the scrolls roll in the water for next to nothing and helixd stops it (a fault, the
    outputs at trim, HOLD) — why a pond survey needs the mode that works there."""
    sitl = pond_sitl
    assert sitl.plant is not None
    mission = MISSIONS / "pond-crossing.yaml"
    daemon = launch(tmp_path, sitl, mission, mode)
    helixd_runs.append(daemon)
    code = daemon.wait_exit(MISSION_WALL_S)
    run_dir = daemon.run_dir()
    summary = json.loads((run_dir / "summary.json").read_text(encoding="utf-8"))
    obs = sitl.obs
    media = sitl.plant.log_tail(200)
    print(
        f"pond crossing, {mode}, SITL: exit {code}, completed {summary['completed']}, "
        f"{summary['waypoints_reached']}/{summary['waypoints_total']} waypoints, "
        f"{summary['duration_s']} s, final error {summary['final_error_m']} m, "
        f"result {summary['fault'] or 'ok'}"
    )
    if mode == "scroll":
        assert code == ExitCode.OK, daemon.log_text()[-4000:]
        assert summary["completed"] is True
        twin = fly_on_builtin_sim(
            tmp_path / "sim",
            mission,
            mode,
            "hard",
            helix_sitl_config("unused"),
            media=POND_MEDIA,
        )
        assert twin.exit_code == ExitCode.OK
        ratio = summary["duration_s"] / twin.summary["duration_s"]
        sitl_j, sim_j = (
            scroll_energy_j(read_flight_columns(d / "flight.csv")) for d in (run_dir, twin.run_dir)
        )
        print(
            f"pond crossing, scroll, helixd sim: {twin.summary['duration_s']} s, final error "
            f"{twin.summary['final_error_m']} m; time ×{ratio:.2f}; energy SITL {sitl_j:.0f} J, "
            f"helixd sim {sim_j:.0f} J"
        )
        assert TIME_RATIO[0] <= ratio <= TIME_RATIO[1]
    else:
        assert code == ExitCode.FAULT, daemon.log_text()[-4000:]
        assert summary["completed"] is False
        obs.wait_until(
            lambda: all_at(obs.servo_pwm(), NEUTRAL_US) and obs.mode() == MODE_HOLD,
            15.0,
            "outputs 1-4 at trim and HOLD after the fault",
        )
    assert "plant_progress" in media  # the plant ran the whole flight


# -- the mode follows the medium -------------------------------------------------------------

POND_MODES = ["roll", "scroll", "roll"]  # the bank, the mud and water, the far bank
STOPPED_MPS = 0.2  # a change of mode happens at the stop (approached at 0.1 m/s, cruise 0.6)
TURN_DRIFT_M = 0.5  # how far the rover may move while it turns in place (about half its length)


@dataclass(frozen=True)
class ModeChange:
    before: str
    after: str
    north_m: float
    east_m: float
    medium: Medium
    speed_mps: float  # measured at the change
    turn_drift_m: float  # moved from the change until it drove on
    turn_translation_mps: float  # the largest translation commanded while it turned


def mode_changes(c: Mapping[str, np.ndarray], media: MediaMapNe) -> list[ModeChange]:
    """Where flight.csv's motion_mode changes, and the turn in place (nav_state ``align``)
    that follows it."""
    modes, nav = c["motion_mode"], c["nav_state"]
    north, east = c["north_m"], c["east_m"]
    out: list[ModeChange] = []
    for i in np.flatnonzero(modes[1:] != modes[:-1]) + 1:
        end = i + 1  # the change (at the stop), then the rows of its turn
        while end < len(nav) and nav[end] == "align":
            end += 1
        turn = slice(i, end)
        translation = np.hypot(c["vx_cmd_mps"][turn], c["vy_cmd_mps"][turn])
        out.append(
            ModeChange(
                str(modes[i - 1]),
                str(modes[i]),
                float(north[i]),
                float(east[i]),
                media.medium_at(float(north[i]), float(east[i])),
                float(c["speed_meas_mps"][i]),
                float(np.hypot(north[end - 1] - north[i], east[end - 1] - east[i])),
                float(np.max(translation)),
            )
        )
    return out


def modes_in_order(modes: np.ndarray) -> list[str]:
    return [str(m) for k, m in enumerate(modes) if k == 0 or m != modes[k - 1]]


@dataclass(frozen=True)
class MediaFlight:
    """A media-policy flight read from its flight.csv."""

    modes: list[str]
    changes: list[ModeChange]
    rows_by: dict[tuple[str, str], int]  # (motion mode, medium under the rover) → rows
    energy_j: float


def media_flight(run_dir: Path, media: MediaMapNe) -> MediaFlight:
    c = read_flight_columns(run_dir / "flight.csv")
    under = [media.medium_at(n, e).value for n, e in zip(c["north_m"], c["east_m"], strict=True)]
    rows_by: dict[tuple[str, str], int] = {}
    for mode, medium in zip(c["motion_mode"], under, strict=True):
        rows_by[(str(mode), medium)] = rows_by.get((str(mode), medium), 0) + 1
    return MediaFlight(
        modes_in_order(c["motion_mode"]), mode_changes(c, media), rows_by, scroll_energy_j(c)
    )


def pond_media_ne() -> MediaMapNe:
    """The pond's media map placed at SITL's home (the EKF origin: flight.csv's frame)."""
    lat, lon = (float(v) for v in POND_HOME.split(",")[:2])
    return read_media_map(POND_MEDIA).to_ne((lat, lon), fallback=Medium.HARD)


def test_pond_crossing_the_mode_follows_the_medium(
    pond_sitl: SitlVehicle, helixd_runs: list[DaemonRun], tmp_path: Path
) -> None:
    """The pond crossing with the map given to helixd (``media.media_map``): it rolls the bank,
    stops short of the mud and turns in place, scrolls the mud and the water, turns back to
    ROLL on the far bank — on real ArduPilot as on the built-in simulator with the same map and
    policy; the fixed-SCROLL twin's time and energy printed beside it."""
    sitl = pond_sitl
    assert sitl.plant is not None
    mission = MISSIONS / "pond-crossing.yaml"
    daemon = launch(tmp_path, sitl, mission, None, media_map=POND_MEDIA)
    helixd_runs.append(daemon)
    code = daemon.wait_exit(MISSION_WALL_S)
    log = daemon.log_text()
    assert code == ExitCode.OK, log[-4000:]
    run_dir = daemon.run_dir()
    summary = json.loads((run_dir / "summary.json").read_text(encoding="utf-8"))
    assert summary["completed"] is True
    assert summary["waypoints_reached"] == summary["waypoints_total"]
    media = pond_media_ne()
    flown = media_flight(run_dir, media)
    twins = {
        policy: fly_on_builtin_sim(
            tmp_path / f"sim-{policy}",
            mission,
            None if policy == "media" else "scroll",
            "hard",
            helixd_config("unused", POND_MEDIA if policy == "media" else None),
            media=POND_MEDIA,
        )
        for policy in ("media", "scroll")
    }
    assert all(t.exit_code == ExitCode.OK for t in twins.values())
    twin = media_flight(twins["media"].run_dir, media)
    fixed = scroll_energy_j(read_flight_columns(twins["scroll"].run_dir / "flight.csv"))
    for c in flown.changes:
        print(
            f"pond crossing, media, SITL: {c.before} → {c.after} at ({c.north_m:.2f}, "
            f"{c.east_m:.2f}) m N/E on {c.medium.value}, {c.speed_mps:.3f} m/s, moved "
            f"{c.turn_drift_m:.2f} m while turning (translation ≤ {c.turn_translation_mps:.2f} "
            "m/s)"
        )
    rows = {
        "SITL, media": (summary, flown.energy_j),
        "helixd sim, media": (twins["media"].summary, twin.energy_j),
        "helixd sim, scroll": (twins["scroll"].summary, fixed),
    }
    for name, (s, energy) in rows.items():
        print(
            f"pond crossing, {name}: {s['duration_s']:.1f} s, {energy:.0f} J, final error "
            f"{s['final_error_m']:.3f} m, {s['waypoints_reached']}/{s['waypoints_total']}"
        )
    ratio = summary["duration_s"] / twins["media"].summary["duration_s"]
    energy_ratio = flown.energy_j / twin.energy_j
    print(
        f"pond crossing, media: SITL/sim time ×{ratio:.2f}, energy ×{energy_ratio:.2f}; "
        f"SITL media / sim scroll time "
        f"×{summary['duration_s'] / twins['scroll'].summary['duration_s']:.2f}, energy "
        f"×{flown.energy_j / fixed:.2f}; rows by (mode, medium) {flown.rows_by}"
    )
    assert flown.modes == POND_MODES == twin.modes
    assert log.count("event=media_transition") == len(POND_MODES) - 1
    assert "ground_changed" not in log  # the map was right: no mode from the ground check
    # ROLL only on the bank; the mud and the water only in SCROLL
    assert {medium for mode, medium in flown.rows_by if mode == "roll"} == {"hard"}
    assert {mode for mode, medium in flown.rows_by if medium != "hard"} == {"scroll"}
    for c in flown.changes:  # stopped on firm ground, turned in place
        assert c.medium is Medium.HARD
        assert c.speed_mps <= STOPPED_MPS
        assert c.turn_translation_mps == 0.0
        assert c.turn_drift_m <= TURN_DRIFT_M
    assert TIME_RATIO[0] <= ratio <= TIME_RATIO[1], f"time ×{ratio:.2f}"
    assert TIME_RATIO[0] <= energy_ratio <= TIME_RATIO[1], f"energy ×{energy_ratio:.2f}"
