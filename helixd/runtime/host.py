"""What a flight runs on: its host, as uvicorn's ``Server`` takes the sockets it is given or
opens its own.

* ``helixd run`` is its own host (:class:`OwnLink`): it connects the link and closes it, owns
  SIGINT/SIGTERM, and waits for the pilot's start switch before arming;
* ``helixd serve`` lends each flight what it holds (:class:`ServeHost`): its link (connected,
  heartbeating, streams negotiated; the flight neither connects nor closes it, but records
  its traffic from its start to its end in its own run directory's ``link.tlog``), its stop
  request (the service owns the signals and pauses through it), its notifier, and where the
  item being flown goes (the GCS's current item). No start gate: the service started the
  flight on the operator's word. A flight the crew started in the autopilot's AUTO drives in
  AUTO (:attr:`FlightHost.driving`): the flight neither sets a mode nor arms; so does a
  flight to the autopilot's own place in GUIDED, RTL or SMART_RTL (``driving.goto``). The
  service hands in how such a flight tells the autopilot's place (``driving.places``).

:class:`helixd.runtime.daemon.MissionRunner` asks its host and never looks at which one it is.
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Protocol

from helixd.base.clock import now_s
from helixd.config.root import HelixdConfig
from helixd.link.connection import Autopilot
from helixd.link.wire.tlog import LinkTlog
from helixd.report.notify import FlightInServiceNotifier, ServiceNotifier
from helixd.runtime.mode_gate import DRIVE_MANUAL, Driving
from helixd.runtime.setup import (
    Held,
    attach,
    close_flight_tlog,
    connect,
    open_flight_tlog,
    reach,
)
from helixd.runtime.signals import StopRequest, install, uninstall
from helixd.safety.supervisor import FallbackReport

__all__ = ["FlightHost", "OnLink", "OwnLink", "ServeHost"]

OnLink = Callable[[Autopilot], None]  # told the link once it is the flight's


class FlightHost(Protocol):
    """What a flight takes from where it runs."""

    @property
    def stop(self) -> StopRequest: ...

    @property
    def notifier(self) -> ServiceNotifier: ...

    @property
    def start_gate(self) -> bool:
        """Wait for the pilot's start switch (``startup.start_switch_channel``) before arming."""
        ...

    @property
    def driving(self) -> Driving:
        """The autopilot's mode the flight drives in: MANUAL (set, then armed, by the flight
        itself; any other mode is a takeover), AUTO (a flight the crew started in the
        autopilot's AUTO: neither set nor armed by the flight, and the mode is the crew's
        command, :mod:`helixd.runtime.mode_gate`) or GUIDED, RTL, SMART_RTL with the
        autopilot's place to drive to and hold at."""
        ...

    @property
    def disarm_when_complete(self) -> bool:
        """A completed mission ends disarmed (``helixd run`` always; ``helixd serve`` as
        ``serve.disarm_when_complete`` says)."""
        ...

    @property
    def tells_steps(self) -> bool:
        """The flight tells the ground station its own steps (preflight, what it flies, a
        handover's where): ``helixd run`` does; a flight of ``helixd serve`` leaves that to
        the service's state texts, so one press of the crew reads as one or two lines."""
        ...

    def signals(self) -> contextlib.AbstractContextManager[None]:
        """While the flight runs: SIGINT/SIGTERM trigger :attr:`stop` (or someone else's do)."""
        ...

    async def reach(self, cfg: HelixdConfig) -> Autopilot | None:
        """Before the run directory exists: make the link, or raise LinkError (a link never
        made leaves nothing behind)."""
        ...

    async def open(
        self, cfg: HelixdConfig, held: Held, on_link: OnLink, run_dir: Path | None
    ) -> Autopilot:
        """The link, the autopilot heard, neutral on the servo outputs (held in ``held``)."""
        ...

    async def close(self, ap: Autopilot) -> None:
        """Give the link back after the flight."""
        ...

    def on_item(self, seq: int) -> None:
        """The mission item being flown, each time it changes."""
        ...

    def secured(self, report: FallbackReport) -> None:
        """The flight's fall-back is done (neutral, released, HOLD asked): its report."""
        ...

    def paused(self, held: bool, mode: str) -> None:
        """The autopilot's ``mode`` paused the flight (``held``: scrolls at neutral until the
        driving mode is back) or let it go on again."""
        ...


class OwnLink:
    """``helixd run``: its own link, signals and start gate."""

    start_gate = True
    tells_steps = True
    disarm_when_complete = True
    driving = DRIVE_MANUAL

    def __init__(self) -> None:
        self.stop = StopRequest()
        self.notifier = ServiceNotifier()  # the run's own (helixd run under systemd)
        self._reached: Autopilot | None = None

    @contextlib.contextmanager
    def signals(self) -> Iterator[None]:
        loop = asyncio.get_running_loop()
        install(loop, self.stop)
        try:
            yield
        finally:
            uninstall(loop)

    async def open(
        self, cfg: HelixdConfig, held: Held, on_link: OnLink, run_dir: Path | None
    ) -> Autopilot:
        ap, self._reached = self._reached, None
        if ap is None:
            ap = await reach(cfg, self.stop)
        return await connect(ap, cfg, held, self.stop, on_link, run_dir)

    async def reach(self, cfg: HelixdConfig) -> Autopilot | None:
        self._reached = await reach(cfg, self.stop)
        return self._reached

    async def close(self, ap: Autopilot) -> None:
        ap.stop_heartbeat()
        await ap.close()

    def on_item(self, seq: int) -> None:
        """Nobody to tell: ``helixd run`` sets no current item."""

    def secured(self, report: FallbackReport) -> None:
        """Nobody to tell: the run ends with it."""

    def paused(self, held: bool, mode: str) -> None:
        """Nobody to tell: ``helixd run`` drives in MANUAL, where another mode is a takeover."""


@dataclass
class ServeHost:
    """``helixd serve``'s link, stop request, notifier and current-item setter, lent to one
    flight; the flight's tlog of the link while it is lent."""

    link: Autopilot
    stop: StopRequest
    notifier: ServiceNotifier = field(default_factory=FlightInServiceNotifier)
    set_item: Callable[[int], None] | None = None  # None: nobody shows the current item
    # the service's state while the autopilot's mode holds the flight: (held, mode)
    on_pause: Callable[[bool, str], None] | None = None
    # AUTO: a flight the crew started in the autopilot's AUTO; GUIDED, RTL, SMART_RTL: to
    # the autopilot's place
    driving: Driving = DRIVE_MANUAL
    disarm_when_complete: bool = True  # serve.disarm_when_complete
    _tlog: LinkTlog | None = field(default=None, init=False, repr=False)
    # when the flight's fall-back had its HOLD acknowledged (None: not asked, or not taken)
    hold_acked_s: float | None = field(default=None, init=False)

    @property
    def start_gate(self) -> bool:
        return False

    @property
    def tells_steps(self) -> bool:
        return False

    def signals(self) -> contextlib.AbstractContextManager[None]:
        return contextlib.nullcontext()  # the service owns them

    async def reach(self, cfg: HelixdConfig) -> Autopilot | None:
        """The service's link is up already."""
        return None

    async def open(
        self, cfg: HelixdConfig, held: Held, on_link: OnLink, run_dir: Path | None
    ) -> Autopilot:
        """The service's link, recorded in the flight's run directory from now on (``attach``
        holds it at once, so the run's shutdown gives it back through :meth:`close`)."""
        self._tlog = open_flight_tlog(self.link, cfg, run_dir)
        return await attach(self.link, cfg, held, self.stop, on_link)

    async def close(self, ap: Autopilot) -> None:
        """The service's link stays up; the flight's tlog ends here."""
        tlog, self._tlog = self._tlog, None
        if tlog is not None:
            close_flight_tlog(ap, tlog)

    def on_item(self, seq: int) -> None:
        if self.set_item is not None:
            self.set_item(seq)

    def secured(self, report: FallbackReport) -> None:
        """The service's AUTO watch takes the HOLD acknowledged as the autopilot out of AUTO
        (:meth:`helixd.serve.core.AutoWatch.left`): a Start right after a fault is a start."""
        if report.hold_acked:
            self.hold_acked_s = now_s()

    def paused(self, held: bool, mode: str) -> None:
        if self.on_pause is not None:
            self.on_pause(held, mode)
