"""The stop request: the first signal asks, the second forces; a pause ends the flight the same
way but as a pause; and the handlers really are the loop's for SIGINT and SIGTERM."""

from __future__ import annotations

import asyncio
import os
import signal

from helixd.runtime.signals import StopRequest, install, uninstall
from helixd.safety.watchdogs import Fault, FaultCause


def test_a_fresh_request_asks_nothing() -> None:
    stop = StopRequest()
    assert not stop.requested and not stop.forced and not stop.event.is_set()


def test_the_first_signal_asks_the_second_forces_and_the_first_name_stays() -> None:
    stop = StopRequest()
    stop.trigger("SIGINT")
    assert stop.requested and not stop.forced and stop.event.is_set()
    stop.trigger("SIGTERM")
    assert stop.forced and stop.count == 2
    assert stop.fault() == Fault(FaultCause.SIGNAL, "SIGINT received")


def test_a_pause_ends_the_flight_as_a_pause_named_by_who_asked() -> None:
    stop = StopRequest()
    stop.pause("start switch RC7 low")
    assert stop.requested and stop.paused
    assert stop.fault() == Fault(FaultCause.PAUSED, "start switch RC7 low")


def test_a_pause_after_a_signal_is_still_the_signal() -> None:
    stop = StopRequest()
    stop.trigger("SIGTERM")
    stop.pause("DO_PAUSE_CONTINUE 0")
    assert not stop.paused and stop.forced
    assert stop.fault() == Fault(FaultCause.SIGNAL, "SIGTERM received")


def test_installed_handlers_turn_a_real_sigterm_into_a_request() -> None:
    async def main() -> StopRequest:
        loop = asyncio.get_running_loop()
        stop = StopRequest()
        install(loop, stop)
        try:
            os.kill(os.getpid(), signal.SIGTERM)
            await asyncio.wait_for(stop.event.wait(), timeout=5.0)  # the handler's set, not a sleep
        finally:
            uninstall(loop)
        return stop

    stop = asyncio.run(main())
    assert stop.requested and stop.signal_name == "SIGTERM"
    assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL  # uninstalled: the default again
