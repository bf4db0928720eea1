"""Missions: file model, validation and resolution into a plan."""

from helixd.mission.model import Mission, MissionFrameKind, MotionMode, load_mission
from helixd.mission.plan import Plan, PlanError, PlanWaypoint, resolve_plan

__all__ = [
    "Mission",
    "MissionFrameKind",
    "MotionMode",
    "Plan",
    "PlanError",
    "PlanWaypoint",
    "load_mission",
    "resolve_plan",
]
