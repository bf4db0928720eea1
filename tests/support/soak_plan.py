"""A random crew day for the soak (tools/soak.py), pure: everything drawn from the day's seed.

A day is a mission with a fence and a list of :class:`Step` s at absolute simulated times:
what a crew presses in QGroundControl (:data:`CREW_ACTIONS`) and what goes wrong
(:data:`FAULT_KINDS`, the built-in simulator's faults). Days are mostly idle with bursts: a
session (upload, start, a few presses and faults seconds apart) then a long quiet stretch, as
a crew's day is. The same seed gives the same day on any machine; a shrunk day is the same
plan with steps left out (:func:`without`).
"""

from __future__ import annotations

import math
import random
from dataclasses import dataclass, field, replace

from pymavlink.dialects.v20 import ardupilotmega as mavlink

# what the crew does, as QGroundControl sends it (tests.support.soak_day performs each)
# restart: the service stopped (SIGTERM, its fall-back) and started again, as systemd does
STOP_WORDS = (
    "pause", "pause_helixd", "manual", "disarm", "switch_low", "radio_mode", "restart",
)  # fmt: skip
GO_WORDS = (
    "start", "start_helixd", "continue", "continue_helixd", "goto", "rtl", "smart_rtl",
    "switch_high",
)  # fmt: skip
NEUTRAL_WORDS = ("upload", "reupload", "set_current", "arm", "speed_helixd")
CREW_ACTIONS = (*NEUTRAL_WORDS, *GO_WORDS, *STOP_WORDS)
# the simulator's faults a day injects (helixd.sim.faults.FAULTS), with their arguments
SIM_FAULTS = (
    "link_drop", "stale_pose", "ekf_unhealthy", "reboot", "gps_loss", "gps_silent",
    "battery_low", "fence_breach", "rc_loss", "stall", "nan_position", "nan_yaw",
    "absurd_position", "time_backwards",
)  # fmt: skip
# the day's own faults, injected by tests.support.soak_day (not the simulator's): full_card,
# the recorder's card full (every write of flight.csv raises ENOSPC) for a while; kill, helixd
# killed with -9 and started again by systemd after RestartSec (tests.support.kill9)
DAY_FAULTS = ("full_card", "kill")
FAULT_KINDS = (*SIM_FAULTS, *DAY_FAULTS)
NAV_WAYPOINT = int(mavlink.MAV_CMD_NAV_WAYPOINT)
FENCE_RADIUS_M = 60.0  # the inclusion circle around home every mission and place stays in
PLACE_RADIUS_M = 35.0  # waypoints and Go-to places within this of home


@dataclass(frozen=True, slots=True)
class Item:
    """One mission item: a waypoint (north/east m from home) or a do command."""

    command: int
    north_m: float = 0.0
    east_m: float = 0.0
    params: tuple[float, ...] = ()

    @property
    def is_nav(self) -> bool:
        return self.command == NAV_WAYPOINT


@dataclass(frozen=True, slots=True)
class Step:
    """At ``at_s`` simulated seconds after the service is up: a crew action or a fault."""

    index: int  # its number in the day's full plan (kept when shrunk)
    at_s: float
    kind: str  # "crew" or "fault"
    name: str
    args: tuple[tuple[str, object], ...] = ()

    def arg(self, key: str, default: object = None) -> object:
        return dict(self.args).get(key, default)

    def describe(self) -> str:
        extra = ", ".join(f"{k}={v}" for k, v in self.args if k != "items")
        return f"#{self.index} t={self.at_s:.1f}s {self.kind} {self.name}" + (
            f" ({extra})" if extra else ""
        )


@dataclass(frozen=True, slots=True)
class DayPlan:
    seed: int
    length_s: float
    steps: tuple[Step, ...]
    missions: tuple[tuple[Item, ...], ...] = field(default=())  # every mission uploaded
    switch: bool = True  # the rover has the start switch (startup.start_switch_channel)
    # a pond on the media map (helixd's media.media_map and the simulator's world): north_min,
    # north_max, east_min, east_max (m from home); None: hard ground everywhere
    water_ne: tuple[float, float, float, float] | None = None

    def without(self, indices: frozenset[int]) -> DayPlan:
        return replace(self, steps=tuple(s for s in self.steps if s.index not in indices))


def waypoints(rng: random.Random, count: int) -> list[tuple[float, float]]:
    """A random walk of ``count`` places within PLACE_RADIUS_M of home, 4–20 m apart."""
    north, east = 0.0, 0.0
    out: list[tuple[float, float]] = []
    while len(out) < count:
        bearing = rng.uniform(0.0, 2.0 * math.pi)
        dist = rng.uniform(4.0, 20.0)
        n, e = north + dist * math.cos(bearing), east + dist * math.sin(bearing)
        if math.hypot(n, e) <= PLACE_RADIUS_M:
            north, east = n, e
            out.append((round(n, 2), round(e, 2)))
    return out


def survey(rng: random.Random) -> list[tuple[float, float]]:
    """A lawnmower block: 2–4 lanes 8–20 m long, 3–6 m apart, somewhere near home."""
    lanes, length, gap = rng.randint(2, 4), rng.uniform(8.0, 20.0), rng.uniform(3.0, 6.0)
    n0, e0 = rng.uniform(-10.0, 10.0), rng.uniform(-10.0, 10.0)
    out: list[tuple[float, float]] = []
    for lane in range(lanes):
        ends = [(n0, e0 + lane * gap), (n0 + length, e0 + lane * gap)]
        out += ends if lane % 2 == 0 else ends[::-1]
    return [(round(n, 2), round(e, 2)) for n, e in out]


def mission(rng: random.Random) -> tuple[Item, ...]:
    """A survey or a random walk, with a DO_CHANGE_SPEED and maybe a DO_JUMP (home is item 0)."""
    places = survey(rng) if rng.random() < 0.4 else waypoints(rng, rng.randint(2, 5))
    items: list[Item] = [Item(mavlink.MAV_CMD_NAV_WAYPOINT)]
    for n, e in places:
        items.append(Item(mavlink.MAV_CMD_NAV_WAYPOINT, n, e))
        if rng.random() < 0.25:
            items.append(
                Item(mavlink.MAV_CMD_DO_CHANGE_SPEED, params=(1.0, round(rng.uniform(0.3, 1.0), 2)))
            )
    if rng.random() < 0.4 and len(items) > 3:
        target = rng.choice([i for i, it in enumerate(items[:4]) if it.is_nav and i > 0])
        items.append(
            Item(mavlink.MAV_CMD_DO_JUMP, params=(float(target), float(rng.randint(1, 2))))
        )
        items.append(Item(mavlink.MAV_CMD_NAV_WAYPOINT, *waypoints(rng, 1)[0]))
    return tuple(items)


def same_size(rng: random.Random, items: tuple[Item, ...]) -> tuple[Item, ...]:
    """The crew's edit: every waypoint moved a little, as many items (a same-size re-upload)."""
    moved = []
    for it in items:
        if it.is_nav and (it.north_m or it.east_m):
            n, e = it.north_m + rng.uniform(-2.0, 2.0), it.east_m + rng.uniform(-2.0, 2.0)
            scale = min(1.0, PLACE_RADIUS_M / max(math.hypot(n, e), 1e-9))
            it = replace(it, north_m=round(n * scale, 2), east_m=round(e * scale, 2))
        moved.append(it)
    return tuple(moved)


WEIGHTS = {  # crew actions within a session: how often each is pressed
    "pause": 4, "pause_helixd": 2, "manual": 2, "disarm": 2, "switch_low": 2, "radio_mode": 1,
    "start": 3, "start_helixd": 2, "continue": 4, "continue_helixd": 2, "goto": 2, "rtl": 1,
    "smart_rtl": 1, "switch_high": 2, "upload": 1, "reupload": 2, "set_current": 2, "arm": 1,
    "speed_helixd": 1, "restart": 1,
}  # fmt: skip
FAULT_ARGS: dict[str, tuple[tuple[str, object], ...]] = {
    "reboot": (),
    "battery_low": (),
    "fence_breach": (),
}


# a day's fault is one of the day's own (DAY_FAULTS) this often, drawn from a second stream
# of the seed so the simulator's faults of every earlier day stay where they were
DAY_FAULT_SHARE = 1.0 / 15.0
# a kill takes the place of a simulator's fault this often, drawn from a third stream of the
# seed (:func:`plan_day`'s ``kills``), so the full cards of every earlier day stay too
KILL_SHARE = 1.0 / 15.0


def fault_step(
    rng: random.Random,
    index: int,
    at_s: float,
    extra: random.Random,
    kills: random.Random | None = None,
) -> Step:
    name = rng.choice(SIM_FAULTS)
    args = FAULT_ARGS.get(name, (("duration_s", round(rng.uniform(2.0, 20.0), 1)),))
    if name == "rc_loss":
        args = (*args, ("kind", rng.choice(("no_pulses", "failsafe_values"))))
    if extra.random() < DAY_FAULT_SHARE:
        name = extra.choice(DAY_FAULTS[:1])  # as drawn before the kill was one of them
        args = (("duration_s", round(extra.uniform(2.0, 30.0), 1)),)
    elif kills is not None and kills.random() < KILL_SHARE:
        name, args = "kill", ()
    return Step(index, at_s, "fault", name, args)


SWITCH_WORDS = ("switch_low", "switch_high")


def crew_step(
    rng: random.Random, index: int, at_s: float, current: tuple[Item, ...], switch: bool
) -> Step:
    names = [n for n in WEIGHTS if switch or n not in SWITCH_WORDS]
    name = rng.choices(names, weights=[WEIGHTS[n] for n in names])[0]
    args: tuple[tuple[str, object], ...] = ()
    if name == "set_current":
        navs = [i for i, it in enumerate(current) if it.is_nav and i > 0]
        args = (("seq", rng.choice(navs)),)
    elif name == "goto":
        ((n, e),) = waypoints(rng, 1)
        args = (("north_m", n), ("east_m", e))
    elif name == "radio_mode":
        args = (("mode", rng.choice(("HOLD", "MANUAL"))),)
    elif name == "speed_helixd":
        args = (("speed_mps", round(rng.uniform(0.3, 1.0), 2)),)
    return Step(index, at_s, "crew", name, args)


def plan_day(seed: int, length_s: float, faults_per_session: float = 1.0) -> DayPlan:
    """The day of ``seed``: sessions of 1–4 minutes (upload, start, presses and faults 2–30 s
    apart) separated by quiet stretches, until ``length_s`` simulated seconds; a day shorter
    than 10 minutes has its gaps shrunk in proportion (the test suite's short days)."""
    rng = random.Random(seed)
    extra = random.Random(f"day-faults-{seed}")  # the day's own faults (DAY_FAULTS)
    kills = random.Random(f"day-kills-{seed}")  # the day's kills (KILL_SHARE)
    scale = min(1.0, length_s / 600.0)
    switch = rng.random() < 0.5
    water_ne = None
    if rng.random() < 0.5:
        n0, e0 = round(rng.uniform(-30.0, 15.0), 1), round(rng.uniform(-30.0, 15.0), 1)
        water_ne = (
            n0,
            n0 + round(rng.uniform(5.0, 15.0), 1),
            e0,
            e0 + round(rng.uniform(5.0, 15.0), 1),
        )
    firsts = ("switch_high",) if switch else ("start", "start_helixd")
    steps: list[Step] = []
    missions: list[tuple[Item, ...]] = []
    t = rng.uniform(5.0, 5.0 + 15.0 * scale)
    current: tuple[Item, ...] = ()
    while t < length_s - 60.0 * scale - 10.0:
        current = mission(rng)
        missions.append(current)
        steps.append(Step(len(steps), t, "crew", "upload", (("items", len(missions) - 1),)))
        t += rng.uniform(3.0, 8.0)
        steps.append(Step(len(steps), t, "crew", rng.choice(firsts)))
        end = t + rng.uniform(60.0, 240.0)
        while t < min(end, length_s - 30.0 * scale - 5.0):
            t += rng.uniform(2.0, 2.0 + 28.0 * scale)
            if rng.random() < faults_per_session / 6.0:
                steps.append(fault_step(rng, len(steps), t, extra, kills))
                continue
            step = crew_step(rng, len(steps), t, current, switch)
            if step.name in ("upload", "reupload"):
                current = mission(rng) if step.name == "upload" else same_size(rng, current)
                missions.append(current)
                step = replace(step, args=(("items", len(missions) - 1),))
            steps.append(step)
        t += rng.uniform(0.1, 0.5) * 600.0 * max(1.0, length_s / 3600.0)  # a quiet stretch
    return DayPlan(seed, length_s, tuple(steps), tuple(missions), switch, water_ne)
