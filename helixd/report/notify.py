"""systemd service notifications (``sd_notify``) for the daemon, through the ``sdnotify`` library.

``ServiceNotifier`` tells systemd (``Type=notify`` units, see ``systemd/helixd@.service``)
that helixd is READY, what it is doing (STATUS, shown by ``systemctl status``), that it is
alive (WATCHDOG) and that it is shutting down (STOPPING). Outside systemd (``NOTIFY_SOCKET``
unset) every call is a no-op.

A notification must never hurt the control loop, so the shell around ``sdnotify`` adds what
the library lacks: the socket is non-blocking (a stalled PID 1 cannot stall the rover), a
failed send is logged once per outage and retried on a fresh connection, never raised;
STATUS text is made single-line ASCII (a newline would inject other assignments, and systemd
ignores a STATUS that is not valid UTF-8 while ``sdnotify`` encodes Latin-1); WATCHDOG pings
are rate-limited to one per half watchdog interval, as ``sd_watchdog_enabled(3)`` advises.
Abstract sockets (``NOTIFY_SOCKET=@name``) are handled by ``sdnotify`` itself.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping

import sdnotify
import structlog

from helixd.base.clock import now_s

log = structlog.get_logger(__name__)

# sd_watchdog_enabled(3): "a daemon sends a keep-alive notification message to the service
# manager every half of the time returned here".
WATCHDOG_PING_FRACTION = 0.5
# systemd reads at most PIPE_BUF (4096) bytes per notification; keep STATUS well inside.
STATUS_MAX_CHARS = 200
_USEC_PER_S = 1_000_000


# ---------------------------------------------------------------------------------------------
# Pure helpers


def parse_watchdog_interval_s(environ: Mapping[str, str], pid: int) -> float | None:
    """The watchdog timeout systemd expects pings within, or None when it expects none.

    Mirrors ``sd_watchdog_enabled(3)``: ``WATCHDOG_USEC`` must be a positive integer, and a
    ``WATCHDOG_PID`` that is set must name this process (else the pings are someone else's).
    """
    usec_text = environ.get("WATCHDOG_USEC", "").strip()
    if not usec_text.isdigit() or int(usec_text) <= 0:
        return None
    pid_text = environ.get("WATCHDOG_PID", "").strip()
    if pid_text and (not pid_text.isdigit() or int(pid_text) != pid):
        return None
    return int(usec_text) / _USEC_PER_S


def sanitize_status(text: str, max_chars: int = STATUS_MAX_CHARS) -> str:
    """One line of printable ASCII (non-ASCII escaped), at most ``max_chars`` characters."""
    one_line = " ".join(text.split())
    ascii_text = one_line.encode("ascii", "backslashreplace").decode("ascii")
    if len(ascii_text) <= max_chars:
        return ascii_text
    return ascii_text[: max_chars - 3] + "..."


# ---------------------------------------------------------------------------------------------
# I/O shell


class ServiceNotifier:
    """sd_notify for helixd: ``ready()``, ``status()``, ``watchdog()``, ``stopping()``.

    Every method returns True when the datagram was handed to the notify socket and False
    when nothing was sent (not under systemd, rate-limited, duplicate STATUS, or a failure —
    which is logged, never raised).
    """

    def __init__(
        self,
        *,
        clock: Callable[[], float] = now_s,
        ping_fraction: float = WATCHDOG_PING_FRACTION,
    ) -> None:
        self._socket_address = os.environ.get("NOTIFY_SOCKET", "")
        self._clock = clock
        self._watchdog_interval_s = parse_watchdog_interval_s(os.environ, os.getpid())
        interval_s = self._watchdog_interval_s
        self._ping_period_s = 0.0 if interval_s is None else interval_s * ping_fraction
        self._notifier: sdnotify.SystemdNotifier | None = None
        self._last_ping_s: float | None = None
        self._last_status: str | None = None
        self._failed_sends = 0

    @property
    def enabled(self) -> bool:
        """True when started by systemd with a notify socket (``NOTIFY_SOCKET`` set)."""
        return bool(self._socket_address)

    @property
    def watchdog_interval_s(self) -> float | None:
        """``WatchdogSec=`` of the unit (from ``WATCHDOG_USEC``), None when no pings expected."""
        return self._watchdog_interval_s if self.enabled else None

    def ready(self, status: str | None = None) -> bool:
        """Start-up finished (``READY=1``): ``systemctl start`` returns, the watchdog starts."""
        self._last_ping_s = None  # systemd's watchdog timer starts now: ping on the next call
        if status is None:
            return self._send("READY=1")
        text = sanitize_status(status)
        sent = self._send(f"READY=1\nSTATUS={text}")
        if sent:
            self._last_status = text
        return sent

    def status(self, text: str) -> bool:
        """Free-form state for ``systemctl status`` (sent only when it changed)."""
        clean = sanitize_status(text)
        if clean == self._last_status:
            return False
        sent = self._send(f"STATUS={clean}")
        if sent:
            self._last_status = clean
        return sent

    def watchdog(self) -> bool:
        """Keep-alive; call every control step — sends at most once per half interval."""
        if self.watchdog_interval_s is None:
            return False
        now_s = self._clock()
        if self._last_ping_s is not None and now_s - self._last_ping_s < self._ping_period_s:
            return False
        sent = self._send("WATCHDOG=1")
        if sent:  # on failure retry at the next call rather than one period later
            self._last_ping_s = now_s
        return sent

    def stopping(self, status: str | None = None) -> bool:
        """Shutdown began (``STOPPING=1``); systemd's TimeoutStopSec= counts from here."""
        if status is None:
            return self._send("STOPPING=1")
        return self._send(f"STOPPING=1\nSTATUS={sanitize_status(status)}")

    def extend_timeout(self, timeout_s: float) -> bool:
        """Ask for ``timeout_s`` more before start/stop times out (``EXTEND_TIMEOUT_USEC``)."""
        return self._send(f"EXTEND_TIMEOUT_USEC={max(0, round(timeout_s * _USEC_PER_S))}")

    def close(self) -> None:
        """Close the notify socket (a later call reconnects)."""
        notifier, self._notifier = self._notifier, None
        if notifier is not None and notifier.socket is not None:
            notifier.socket.close()

    def _connect(self) -> sdnotify.SystemdNotifier:
        # debug=True: let sdnotify raise instead of silently dropping every notification.
        notifier = sdnotify.SystemdNotifier(debug=True)
        notifier.socket.setblocking(False)
        return notifier

    def _send(self, message: str) -> bool:
        if not self.enabled:
            return False
        try:
            if self._notifier is None:
                self._notifier = self._connect()
            self._notifier.notify(message)
        except Exception as exc:  # any failure: log once per outage, never raise into the loop
            self.close()
            self._failed_sends += 1
            if self._failed_sends == 1:
                log.warning(
                    "sd_notify_failed",
                    notify_socket=self._socket_address,
                    message=message.split("\n", 1)[0],
                    error=repr(exc),
                )
            return False
        if self._failed_sends:
            log.info("sd_notify_recovered", failed_sends=self._failed_sends)
            self._failed_sends = 0
        return True


class FlightInServiceNotifier(ServiceNotifier):
    """sd_notify for one flight inside ``helixd serve``: READY and STOPPING are the service's
    to say (a flight ending is not the service stopping); the flight's STATUS lines and
    watchdog pings go through as for ``helixd run``."""

    def ready(self, status: str | None = None) -> bool:
        return False if status is None else self.status(status)

    def stopping(self, status: str | None = None) -> bool:
        return False if status is None else self.status(status)
