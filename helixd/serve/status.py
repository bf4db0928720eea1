"""The service's state word, as the crew sees it in three places at once: systemd's status
line, a STATUSTEXT to the ground station, and NAMED_VALUE_INT ``hx_state`` (its number,
sent again at ``serve.state_rate_hz`` so a ground station that connects later sees it)."""

from __future__ import annotations

import contextlib

import structlog
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.base.clock import now_s
from helixd.config.root import HelixdConfig
from helixd.link.connection import Autopilot
from helixd.mav.constants import MAV_SEVERITY_NOTICE
from helixd.mav.url import LinkError
from helixd.report.gcs_feed import GcsFeed
from helixd.report.notify import ServiceNotifier
from helixd.serve.core import ServeState

log = structlog.get_logger(__name__)
_mav = mavlink.MAVLink(None)  # encoder only: Autopilot.send_message packs with our ids

HX_STATE_NAME = b"hx_state"


class ServeStatus:
    """The state and its text (the refusal, the fault, …), told wherever the crew looks."""

    def __init__(self, cfg: HelixdConfig, notifier: ServiceNotifier, gcs: GcsFeed) -> None:
        self.cfg = cfg
        self.notifier = notifier
        self.gcs = gcs
        self.state = ServeState.CONNECTING
        self.detail = ""
        self.ap: Autopilot | None = None  # the link hx_state goes out on, while there is one
        self.next_send_s = 0.0
        # a flight in the autopilot's AUTO held by the crew's HOLD (the flight goes on, paused):
        # told as PAUSED while :attr:`state` stays FLYING for the service's decisions
        self.held = False

    @property
    def shown(self) -> ServeState:
        """The state the crew sees (hx_state, systemd, the log): PAUSED while a flight is held."""
        return ServeState.PAUSED if self.held and self.state is ServeState.FLYING else self.state

    def hold(self, held: bool, why: str = "") -> None:
        """The flight in progress was paused by the autopilot's mode (HOLD and the like; ``why``
        names it) or goes on (AUTO again): hx_state 5 or 4 at once, logged and told to
        systemd; the GCS text is the flight's own ("paused: mode HOLD, …", "continuing in
        AUTO")."""
        was, self.held = self.held, held
        if held is was or self.state is not ServeState.FLYING:
            return
        shown = self.shown
        detail = why if held else self.detail
        log.info("serve_state", state=shown.name.lower(), hx_state=int(shown), detail=detail)
        self.notifier.status(shown.name.lower() + (f": {detail}" if detail else ""))
        self.send()

    def set(
        self, state: ServeState, detail: str = "", severity: int | None = None, quiet: bool = False
    ) -> None:
        """A new state (or text): logged, systemd's status, the GCS told (unless ``quiet``: a
        state between two flights of one press of the crew), hx_state sent."""
        if state is self.state and detail == self.detail and not self.held:
            return
        self.state, self.detail, self.held = state, detail, False
        text = state.name.lower() + (f": {detail}" if detail else "")
        log.info("serve_state", state=state.name.lower(), hx_state=int(state), detail=detail)
        self.notifier.status(text)
        if not quiet:
            self.gcs.say(text, severity or MAV_SEVERITY_NOTICE)
        self.send()

    def send(self) -> None:
        """NAMED_VALUE_INT hx_state now (and not again before the next period)."""
        ap = self.ap
        if ap is None:
            return
        boot_ms = int(now_s() * 1000) & 0xFFFFFFFF
        with contextlib.suppress(LinkError, OSError):
            ap.send_message(_mav.named_value_int_encode(boot_ms, HX_STATE_NAME, int(self.shown)))
        self.next_send_s = now_s() + 1.0 / self.cfg.serve.state_rate_hz

    def due(self, now_s: float) -> bool:
        return now_s >= self.next_send_s


__all__ = ["HX_STATE_NAME", "ServeStatus"]
