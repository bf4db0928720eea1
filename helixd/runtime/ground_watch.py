"""The flight loop's watch on the ground (the shell around :mod:`helixd.control.ground_check`):
each control step's sent and measured motion in, the navigator's mode overridden where the
ground is not what the map says, and the change handed to ``on_ground`` (the run logs it as
an event and tells the ground station in words)."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from helixd.base.geometry import BodyVelocity
from helixd.base.plan import MotionMode
from helixd.config.media import MediaConfig
from helixd.control.ground_check import GroundCheck, GroundCheckParams, GroundVerdict
from helixd.control.navigator import Navigator
from helixd.planning.media_modes import ModePolicy


@dataclass(frozen=True, slots=True)
class GroundChange:
    """The mode changed because of the ground: ``verdict`` at plan waypoint ``target_index``
    (the leg being flown), the rover at ``north_m``/``east_m``, ``planned`` the map's mode."""

    verdict: GroundVerdict
    planned: MotionMode
    target_index: int
    north_m: float
    east_m: float

    def text(self) -> str:
        """What the ground station reads."""
        v = self.verdict
        pct = round(100.0 * v.fraction)  # one STATUSTEXT: at most 42 characters
        if v.soft:
            return f"softer than mapped ({pct}% of {v.judged.value}): {v.mode.value}"
        return f"firm again ({pct}% of {v.judged.value}): back to {v.mode.value}"


def check_params(media: MediaConfig) -> GroundCheckParams:
    """The check's thresholds, and its modes from the mode policy (``media.modes``; with
    ``learned``, the config's defaults: the profile is the plan's, not the check's)."""
    policy = ModePolicy.from_config(media)
    return GroundCheckParams(
        firm_mode=policy.firm_mode,
        soft_mode=policy.soft_mode,
        window_m=media.detect_window_m,
        roll_fraction=media.detect_roll_fraction,
        scroll_fraction=media.detect_scroll_fraction,
        hysteresis=media.detect_hysteresis,
        min_change_m=media.detect_min_change_m,
    )


class GroundWatch:
    """One flight's watch; inactive (``enabled`` False) without a plan that follows the
    medium or with ``media.detect`` off."""

    def __init__(
        self,
        media: MediaConfig,
        navigator: Navigator,
        enabled: bool,
        on_ground: Callable[[GroundChange], None] | None,
    ) -> None:
        self.check = GroundCheck(check_params(media))
        self.navigator = navigator
        self.enabled = enabled and media.detect
        self.on_ground = on_ground
        self._index = -1

    def feed(
        self,
        sent: BodyVelocity,
        measured: BodyVelocity,
        dt_s: float,
        north_m: float,
        east_m: float,
        xy_m: tuple[float, float] | None = None,
    ) -> None:
        """One step: what was sent at the last step and what was measured since (``xy_m``:
        the rover in the mission frame, to read the map's spans on the leg)."""
        if not self.enabled:
            return
        nav = self.navigator
        index = nav.target_index
        if index != self._index:  # a new leg: the plan's mode again, a fresh window
            self._index = index
            self.check.reset()
        planned = nav.plan.mode_at(index)
        vetoed = xy_m is not None and self._map_says_unfit(index, xy_m)
        verdict = self.check.update(nav.mode, sent, measured, dt_s, vetoed)
        if verdict is None:
            return
        nav.override_mode(None if verdict.mode is planned else verdict.mode)
        if self.on_ground is not None:
            self.on_ground(GroundChange(verdict, planned, index, north_m, east_m))

    def _map_says_unfit(self, index: int, xy_m: tuple[float, float]) -> bool:
        """The map has ground the leg's planned mode cannot move in here or within
        ``min_change_m`` ahead (to go, along the leg to waypoint ``index``)."""
        wps = self.navigator.plan.waypoints
        if not 0 <= index < len(wps) or not wps[index].unfit_to_go_m:
            return False
        target = wps[index]
        to_go = math.hypot(target.x_m - xy_m[0], target.y_m - xy_m[1])
        ahead = self.check.params.min_change_m
        return any(near <= to_go and to_go - ahead <= far for near, far in target.unfit_to_go_m)


__all__ = ["GroundChange", "GroundWatch", "check_params"]
