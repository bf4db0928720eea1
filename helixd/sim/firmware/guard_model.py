"""helixd-guard, the autopilot's dead-man switch, as a pure state machine (no sockets, no clocks).

This mirrors ``helixd/mav/scripts/helixd-guard.lua`` (version 1) line for line, so that the
built-in simulator can run the same guard ArduPilot runs (its parameters, their defaults and
:class:`helixd.mav.guard_script.GuardParams` live in :mod:`helixd.mav.guard_script`, shared
with preflight):

* parameters HXG_ENABLE (1), HXG_TIMEOUT (0.5 s, clamped to 0.1 … 10 s), HXG_CHAN1..4
  (1, 2, 3, 4: 1-based servo outputs, 0 = none, outside 1..16 ignored, duplicates once),
  HXG_VERSION (1, set by the script);
* every 50 ms (``UPDATE_PERIOD_MS``): armed and helixd *silent* — never heard since boot
  (``last_gcs_heartbeat_s`` None, as ArduPilot's ``gcs:last_seen()`` 0) or ``now − last >
  timeout`` in whole milliseconds — → the guarded outputs are held at their SERVOn_TRIM for
  ``OVERRIDE_MS`` (renewed each step while the silence lasts), HOLD (Rover mode 4) is asked
  once per episode unless already in HOLD, and one CRITICAL STATUSTEXT is sent;
* when helixd is heard again, the vehicle is disarmed or HXG_ENABLE is 0, it lets go: no more
  renewals and one NOTICE STATUSTEXT. Disarmed it never acts;
* pilot takeover: while guarding it keeps ``base_mode`` (HOLD once granted or seen, else the
  mode found at engagement); a mode other than HOLD and other than ``base_mode`` lets go at once
  (:attr:`GuardAction.release_rc`: clear its RC overrides of the passthrough inputs; one NOTICE
  :func:`takeover_text`) and it stays released until helixd is heard again (last heard newer
  than the release), a disarm or HXG_ENABLE 0. The edge cases are written down in the Lua's
  header. The shell reports a granted HOLD request with :meth:`HelixdGuard.hold_granted`
  (the Lua's ``vehicle:set_mode`` returning true).

The Lua holds an RC-passthrough output at trim by overriding its RC input as well (ArduPilot
copies the RC input onto a passthrough output after a servo override); here that is the
shell's business: :attr:`GuardAction.hold_trim` lists the outputs, the simulator applies
SERVOn_TRIM. If the shell's HOLD request fails it sends :data:`HOLD_REFUSED_TEXT`.
Times are quantised to whole milliseconds, as ArduPilot's ``millis()``.
"""

from __future__ import annotations

from dataclasses import dataclass

from helixd.mav.guard_script import VERSION, GuardParams, to_ms

UPDATE_PERIOD_MS = 50
OVERRIDE_MS = 100  # each renewal holds the outputs this long (2 update periods)
MODE_HOLD = 4

SEVERITY_CRITICAL = 2
SEVERITY_WARNING = 4
SEVERITY_NOTICE = 5
SEVERITY_INFO = 6

TEXT_PREFIX = "helixd-guard: "
NEVER_SEEN_TEXT = "helixd-guard: no heartbeat yet, trim + HOLD"
HOLD_REFUSED_TEXT = "helixd-guard: HOLD refused"
BACK_TEXT = "helixd-guard: heartbeat back, released"
DISARMED_TEXT = "helixd-guard: disarmed, released"
DISABLED_TEXT = "helixd-guard: disabled, released"


def silent_text(timeout_ms: int) -> str:
    return f"helixd-guard: no heartbeat {timeout_ms} ms, trim + HOLD"


def takeover_text(mode: int) -> str:
    """NOTICE when a human left the guard's mode: ``mode`` is the Rover mode number."""
    return f"helixd-guard: mode {mode}, pilot in charge, released"


@dataclass(frozen=True, slots=True)
class GuardAction:
    """What one step asks of the autopilot."""

    hold_trim: tuple[int, ...] = ()  # outputs (1-based) to hold at SERVOn_TRIM for hold_ms
    hold_ms: int = 0
    request_hold: bool = False  # vehicle:set_mode(4); on failure send HOLD_REFUSED_TEXT
    texts: tuple[tuple[int, str], ...] = ()  # (MAV_SEVERITY, STATUSTEXT)
    guarding: bool = False  # state after this step
    release_rc: tuple[int, ...] = ()  # outputs (1-based) whose passthrough RC override to clear


def start_text(params: GuardParams) -> tuple[int, str]:
    """The INFO STATUSTEXT the script sends when it loads."""
    outputs = " ".join(str(n) for n in params.outputs) or "none"
    state = "on" if params.enabled else "off"
    return (
        SEVERITY_INFO,
        f"helixd-guard: v{VERSION} {state}, outputs {outputs}, {params.timeout_ms} ms",
    )


class HelixdGuard:
    """One guard instance; call :meth:`step` every ``UPDATE_PERIOD_MS`` of autopilot time.

    ``params`` may be replaced between steps (the script reads its parameters every update).
    """

    def __init__(self, params: GuardParams | None = None) -> None:
        self.params = params if params is not None else GuardParams()
        self.guarding = False
        self.base_mode: int | None = None  # while guarding: the mode it expects
        self.released_ms: int | None = None  # millis() of a takeover release (None: not)

    def hold_granted(self) -> None:
        """The shell's HOLD request (``request_hold``) succeeded: the Lua's
        ``if vehicle:set_mode(MODE_HOLD) then base_mode = MODE_HOLD``."""
        if self.guarding:
            self.base_mode = MODE_HOLD

    def step(
        self, now_s: float, armed: bool, last_gcs_heartbeat_s: float | None, mode: int
    ) -> GuardAction:
        p = self.params
        now_ms = to_ms(now_s)
        never = last_gcs_heartbeat_s is None or to_ms(last_gcs_heartbeat_s) == 0
        tmo = p.timeout_ms
        silent = never or (
            last_gcs_heartbeat_s is not None and now_ms - to_ms(last_gcs_heartbeat_s) > tmo
        )

        if not p.enabled:
            self.released_ms = None
            if self.guarding:
                self.guarding = False
                return GuardAction(texts=((SEVERITY_NOTICE, DISABLED_TEXT),))
            return GuardAction()

        if self.released_ms is not None:
            # a pilot took over: hands off until disarm or until helixd is heard again
            heard_since = (
                not never
                and last_gcs_heartbeat_s is not None
                and to_ms(last_gcs_heartbeat_s) - self.released_ms > 0
            )
            if not armed or heard_since:
                self.released_ms = None
            else:
                return GuardAction()

        if armed and silent:
            texts: tuple[tuple[int, str], ...] = ()
            request_hold = False
            if not self.guarding:
                self.guarding = True
                self.base_mode = mode
                text = NEVER_SEEN_TEXT if never else silent_text(tmo)
                texts = ((SEVERITY_CRITICAL, text),)
                request_hold = mode != MODE_HOLD  # granted: the shell calls hold_granted()
            elif mode == MODE_HOLD:
                self.base_mode = MODE_HOLD
            elif mode != self.base_mode:
                # a human (mode switch, ground station) left the guard's mode: let go
                self.guarding = False
                self.base_mode = None
                self.released_ms = now_ms
                return GuardAction(
                    texts=((SEVERITY_NOTICE, takeover_text(mode)),), release_rc=p.outputs
                )
            return GuardAction(
                hold_trim=p.outputs,
                hold_ms=OVERRIDE_MS,
                request_hold=request_hold,
                texts=texts,
                guarding=True,
            )

        if self.guarding:
            self.guarding = False
            self.base_mode = None
            text = BACK_TEXT if armed else DISARMED_TEXT
            return GuardAction(texts=((SEVERITY_NOTICE, text),))
        return GuardAction()


def passthrough_input(output: int, function: int) -> tuple[int | None, bool]:
    """The Lua's ``passthrough_input``: the RC input (1-based) that feeds an RC-passthrough
    output (None if ``function`` is no passthrough), and whether it is a *mapped* passthrough
    (140..155), held at that input's RCn_TRIM rather than the output's SERVOn_TRIM."""
    if function == 1:
        return output, False  # k_manual: RC input n -> output n
    if 51 <= function <= 66:
        return function - 50, False  # k_rcin1..16
    if 140 <= function <= 155:
        return function - 139, True  # k_rcin1_mapped..16
    return None, False
