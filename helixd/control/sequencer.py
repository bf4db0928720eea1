"""The mission sequencer: which navigation step is active, what waits, and which of the
mission's do/condition items are due — beside the navigator, which only flies legs.

Pure: stepped with the autopilot clock (s), the waypoint the navigator reported reached on
this step (if any) and the distance to its current target; it returns what is due now. The
flight loop (:mod:`helixd.runtime.flight`) performs it: sends the payload commands, sets the
navigator's speed and direction, and keeps the scrolls stopped while the sequencer holds.

Semantics are ArduPilot's (``AP_Mission::update``, ``Rover/mode_auto.cpp``), on the program
:mod:`helixd.mission.expand` built:

* a step starts when the one before it completes; its do/condition items start with it and run
  in order, a CONDITION_DELAY holding the ones after it until its time has passed (measured
  from when the condition started), a CONDITION_DISTANCE until the rover is closer than its
  distance to the target; when the step completes, the ones still waiting are dropped;
* a step that drives completes when the navigator reaches its last waypoint — after waiting
  its hold there; a step in place (a delay, a hold where the rover stands) completes after its
  hold; NAV_LOITER_UNLIM never completes;
* after the last step the program's final items run and the sequencer is done.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from helixd.base.plan import ActionKind, MissionAction, NavStep, Program

MAX_STEPS_PER_UPDATE = 10_000  # in-place steps without a wait complete within one update


@dataclass(frozen=True, slots=True)
class SequencerEvent:
    """Something the run's events should record (``kind``: step_started, step_completed,
    hold_started, item_skipped, item_dropped)."""

    kind: str
    item: int
    command: int
    text: str
    step: int  # index of the step in the program


@dataclass(frozen=True, slots=True)
class SequencerOutput:
    actions: tuple[MissionAction, ...]  # due now, in mission order (SEND, SPEED, REVERSE, NOTE)
    holding: bool  # keep the scrolls stopped; the navigator is not stepped
    done: bool  # the whole program has run
    events: tuple[SequencerEvent, ...]
    step: int  # the active step (len(steps) when done)


class Sequencer:
    """Steps through one :class:`Program`. Construct, :meth:`start`, then :meth:`update`."""

    def __init__(self, program: Program) -> None:
        self.program = program
        self._steps = program.steps
        self._index = -1
        self._holding = False
        self._arrived = False
        self._hold_until_s = math.inf
        self._pending: list[MissionAction] = []  # do items of the active step not yet run
        self._wait_since_s: float | None = None  # when the waiting CONDITION_DELAY started

    @property
    def step_index(self) -> int:
        return self._index

    @property
    def done(self) -> bool:
        """Past the last step (only :meth:`_advance` moves the index, never back)."""
        return self._index >= len(self._steps)

    def current(self) -> NavStep | None:
        if 0 <= self._index < len(self._steps):
            return self._steps[self._index]
        return None

    def start(self, t_s: float) -> SequencerOutput:
        """Start the first step (and whatever completes at once after it)."""
        if not math.isfinite(t_s):
            raise ValueError("sequencer time must be finite")
        actions: list[MissionAction] = []
        events: list[SequencerEvent] = []
        self._advance(t_s, actions, events)
        return self._output(actions, events)

    def update(self, t_s: float, reached_index: int | None, distance_m: float) -> SequencerOutput:
        """One control step: ``reached_index`` is the plan waypoint the navigator reached on
        this step (None: none), ``distance_m`` its distance to the current target."""
        if not math.isfinite(t_s):
            raise ValueError("sequencer time must be finite")
        actions: list[MissionAction] = []
        events: list[SequencerEvent] = []
        if self.done:
            return self._output(actions, events)
        step = self.current()
        if (
            step is not None
            and not self._holding
            and reached_index is not None
            and step.last_waypoint == reached_index
        ):
            self._arrive(step, t_s, events)
        self._run_pending(t_s, distance_m if not self._holding else 0.0, actions)
        if self._holding and self._hold_ended(t_s):
            self._complete(t_s, actions, events)
        return self._output(actions, events)

    @property
    def holding_forever(self) -> bool:
        """Arrived at a NAV_LOITER_UNLIM: holding until the operator continues."""
        step = self.current()
        return self._holding and not self.done and step is not None and step.forever

    def release_hold(self) -> bool:
        """The operator continues (``helixd serve``: DO_PAUSE_CONTINUE 1): a NAV_LOITER_UNLIM
        hold ends at the next update. False (nothing changed) when not holding at one."""
        if not self.holding_forever:
            return False
        self._hold_until_s = -math.inf
        return True

    # -- internals ---------------------------------------------------------------------------

    def _output(
        self, actions: list[MissionAction], events: list[SequencerEvent]
    ) -> SequencerOutput:
        return SequencerOutput(
            tuple(actions), self._holding and not self.done, self.done, tuple(events),
            self._index,
        )  # fmt: skip

    def _arrive(self, step: NavStep, t_s: float, events: list[SequencerEvent]) -> None:
        self._arrived = True
        self._holding = True
        self._hold_until_s = math.inf if step.forever else t_s + step.hold_s
        if step.hold_s > 0.0 or step.forever:
            how = "until the operator continues" if step.forever else f"{step.hold_s:g} s"
            events.append(self._event("hold_started", step, f"holding {how}"))

    def _hold_ended(self, t_s: float) -> bool:
        return t_s >= self._hold_until_s

    def _complete(
        self, t_s: float, actions: list[MissionAction], events: list[SequencerEvent]
    ) -> None:
        step = self.current()
        if step is not None:
            for a in self._pending:
                events.append(
                    SequencerEvent(
                        "item_dropped",
                        a.item,
                        a.command,
                        f"{a.text}: not run (its step ended first, as ArduPilot drops it)",
                        self._index,
                    )
                )
            self._pending = []
            events.append(self._event("step_completed", step, step.text))
        self._advance(t_s, actions, events)

    def _advance(
        self, t_s: float, actions: list[MissionAction], events: list[SequencerEvent]
    ) -> None:
        """Start the next step; in-place steps without a wait complete at once."""
        for _ in range(MAX_STEPS_PER_UPDATE):
            self._index += 1
            self._wait_since_s = None
            if self._index >= len(self._steps):
                actions.extend(self.program.final_actions)
                self._holding = False
                return
            step = self._steps[self._index]
            for text in step.skipped:
                events.append(self._event("item_skipped", step, text))
            events.append(self._event("step_started", step, step.text))
            self._pending = list(step.actions)
            self._arrived = False
            self._run_pending(t_s, 0.0 if step.last_waypoint is None else math.inf, actions)
            if step.last_waypoint is not None:
                self._holding = False
                self._hold_until_s = math.inf
                return
            # in place: the whole step is its hold
            self._holding = True
            self._arrive(step, t_s, events)
            if not self._hold_ended(t_s):
                return
            for a in self._pending:
                events.append(
                    SequencerEvent(
                        "item_dropped", a.item, a.command, f"{a.text}: not run", self._index
                    )
                )
            self._pending = []
            events.append(self._event("step_completed", step, step.text))
        raise RuntimeError("the program completes more steps in place than it can hold")

    def _run_pending(self, t_s: float, distance_m: float, actions: list[MissionAction]) -> None:
        """Run the active step's do items up to the first condition still waiting."""
        while self._pending:
            a = self._pending[0]
            if a.kind is ActionKind.WAIT_TIME:
                if self._wait_since_s is None:
                    self._wait_since_s = t_s
                if not t_s - self._wait_since_s > a.value:  # verify_wait_delay: strictly more
                    return
                self._wait_since_s = None
            elif a.kind is ActionKind.WAIT_DISTANCE:
                if not distance_m < a.value:  # verify_within_distance
                    return
            else:
                actions.append(a)
            self._pending.pop(0)

    def _event(self, kind: str, step: NavStep, text: str) -> SequencerEvent:
        return SequencerEvent(kind, step.item, step.command, text, self._index)


__all__ = ["Sequencer", "SequencerEvent", "SequencerOutput"]
