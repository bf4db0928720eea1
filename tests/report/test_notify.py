"""helixd.report.notify: real AF_UNIX datagram sockets stand in for systemd's notify socket."""

from __future__ import annotations

import os
import socket
import uuid
from collections.abc import Iterator
from pathlib import Path

import pytest
from structlog.testing import capture_logs

from helixd.report.notify import ServiceNotifier, parse_watchdog_interval_s, sanitize_status

RECV_TIMEOUT_S = 10.0  # generous: the machine is shared; a datagram arrives in microseconds
SENTINEL = b"SENTINEL"


class FakeClock:
    def __init__(self) -> None:
        self.now_s = 100.0

    def __call__(self) -> float:
        return self.now_s


def recv(sock: socket.socket) -> bytes:
    sock.settimeout(RECV_TIMEOUT_S)
    return sock.recv(4096)


def assert_nothing_queued(sock: socket.socket, address: str | bytes) -> None:
    """Datagram order is FIFO: if our own sentinel comes out first, nothing else was queued."""
    with socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM) as tx:
        tx.sendto(SENTINEL, address)
    assert recv(sock) == SENTINEL


@pytest.fixture
def clean_env(monkeypatch: pytest.MonkeyPatch) -> None:
    for name in ("NOTIFY_SOCKET", "WATCHDOG_USEC", "WATCHDOG_PID"):
        monkeypatch.delenv(name, raising=False)


@pytest.fixture
def path_socket(tmp_path: Path, clean_env: None) -> Iterator[tuple[socket.socket, str]]:
    path = str(tmp_path / "notify")
    with socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM) as sock:
        sock.bind(path)
        yield sock, path


@pytest.fixture
def abstract_socket(clean_env: None) -> Iterator[tuple[socket.socket, str]]:
    name = f"helixd-test-{uuid.uuid4().hex}"
    with socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM) as sock:
        sock.bind("\0" + name)
        yield sock, "@" + name


@pytest.mark.parametrize("which", ["path_socket", "abstract_socket"])
def test_lifecycle_datagrams_arrive(
    which: str, request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch
) -> None:
    sock, address = request.getfixturevalue(which)
    monkeypatch.setenv("NOTIFY_SOCKET", address)
    monkeypatch.setenv("WATCHDOG_USEC", "5000000")
    monkeypatch.setenv("WATCHDOG_PID", str(os.getpid()))
    notifier = ServiceNotifier()
    assert notifier.enabled
    assert notifier.watchdog_interval_s == pytest.approx(5.0)
    try:
        assert notifier.ready()
        assert recv(sock) == b"READY=1"
        assert notifier.status("preflight passed, waypoint 1/4")
        assert recv(sock) == b"STATUS=preflight passed, waypoint 1/4"
        assert notifier.watchdog()
        assert recv(sock) == b"WATCHDOG=1"
        assert notifier.extend_timeout(2.5)
        assert recv(sock) == b"EXTEND_TIMEOUT_USEC=2500000"
        assert notifier.stopping("fall-back: HOLD")
        assert recv(sock) == b"STOPPING=1\nSTATUS=fall-back: HOLD"
        assert notifier.ready("armed")
        assert recv(sock) == b"READY=1\nSTATUS=armed"
    finally:
        notifier.close()


def test_unset_notify_socket_is_a_noop(
    path_socket: tuple[socket.socket, str], monkeypatch: pytest.MonkeyPatch
) -> None:
    sock, address = path_socket
    monkeypatch.setenv("WATCHDOG_USEC", "5000000")  # even with a watchdog configured
    notifier = ServiceNotifier()
    assert not notifier.enabled
    assert notifier.watchdog_interval_s is None
    with capture_logs() as logs:
        results = [
            notifier.ready("x"),
            notifier.status("y"),
            notifier.watchdog(),
            notifier.extend_timeout(1.0),
            notifier.stopping(),
        ]
        notifier.close()
    assert results == [False] * 5
    assert logs == []
    assert_nothing_queued(sock, address)


def test_watchdog_is_rate_limited_to_half_the_interval(
    path_socket: tuple[socket.socket, str], monkeypatch: pytest.MonkeyPatch
) -> None:
    sock, address = path_socket
    monkeypatch.setenv("NOTIFY_SOCKET", address)
    monkeypatch.setenv("WATCHDOG_USEC", "2000000")
    clock = FakeClock()
    notifier = ServiceNotifier(clock=clock)
    sent = []
    for step in range(51):  # 50 Hz control steps over 1.0 s
        clock.now_s = 100.0 + step * 0.02
        sent.append(notifier.watchdog())
    # pings at t=0 and t=1.0 (half of 2 s) only
    assert [i for i, s in enumerate(sent) if s] == [0, 50]
    assert recv(sock) == b"WATCHDOG=1"
    assert recv(sock) == b"WATCHDOG=1"
    assert_nothing_queued(sock, address)
    # READY restarts systemd's watchdog timer: the next call pings at once
    clock.now_s += 0.1
    assert notifier.ready()
    assert notifier.watchdog()
    assert recv(sock) == b"READY=1"
    assert recv(sock) == b"WATCHDOG=1"
    notifier.close()


def notifier_on(
    path_socket: tuple[socket.socket, str], monkeypatch: pytest.MonkeyPatch
) -> tuple[socket.socket, str, ServiceNotifier]:
    """A notifier whose NOTIFY_SOCKET is the test's socket: (socket, its address, notifier)."""
    sock, address = path_socket
    monkeypatch.setenv("NOTIFY_SOCKET", address)
    return sock, address, ServiceNotifier()


def test_no_watchdog_pings_without_watchdog_usec(
    path_socket: tuple[socket.socket, str], monkeypatch: pytest.MonkeyPatch
) -> None:
    sock, address, notifier = notifier_on(path_socket, monkeypatch)
    assert notifier.enabled
    assert notifier.watchdog_interval_s is None
    assert not notifier.watchdog()
    assert_nothing_queued(sock, address)
    notifier.close()


def test_status_is_single_line_ascii_and_deduplicated(
    path_socket: tuple[socket.socket, str], monkeypatch: pytest.MonkeyPatch
) -> None:
    sock, address, notifier = notifier_on(path_socket, monkeypatch)
    # a newline must not inject a second assignment; non-ASCII must stay valid UTF-8
    assert notifier.status("heading 90° →\nREADY=1")
    data = recv(sock)
    assert data == b"STATUS=heading 90\\xb0 \\u2192 READY=1"
    assert b"\n" not in data
    assert not notifier.status("heading 90° →\nREADY=1")  # unchanged: not re-sent
    assert notifier.status("waypoint 2/4")
    assert recv(sock) == b"STATUS=waypoint 2/4"
    assert_nothing_queued(sock, address)
    notifier.close()


def test_send_failure_never_raises_warns_once_and_recovers(
    tmp_path: Path, clean_env: None, monkeypatch: pytest.MonkeyPatch
) -> None:
    path = str(tmp_path / "not-yet")
    monkeypatch.setenv("NOTIFY_SOCKET", path)
    monkeypatch.setenv("WATCHDOG_USEC", "1000000")
    notifier = ServiceNotifier()
    with capture_logs() as logs:
        assert not notifier.ready()
        assert not notifier.status("a")
        assert not notifier.watchdog()
        assert not notifier.watchdog()  # retried at once, not one period later
        assert not notifier.stopping()
    warnings = [e for e in logs if e["event"] == "sd_notify_failed"]
    assert len(warnings) == 1
    assert warnings[0]["log_level"] == "warning"
    assert warnings[0]["notify_socket"] == path
    assert warnings[0]["message"] == "READY=1"

    with socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM) as sock:
        sock.bind(path)
        with capture_logs() as logs:
            assert notifier.status("b")
        assert recv(sock) == b"STATUS=b"
        assert [e["event"] for e in logs] == ["sd_notify_recovered"]
        assert logs[0]["failed_sends"] == 5
    notifier.close()


def test_full_socket_queue_does_not_block_the_caller(
    path_socket: tuple[socket.socket, str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """Nobody reads the socket (a stalled PID 1): sends fail fast instead of blocking."""
    sock, _, notifier = notifier_on(path_socket, monkeypatch)
    with capture_logs() as logs:
        results = [notifier.status(f"step {i}") for i in range(2000)]
    assert results[0] is True
    assert results.count(False) > 0  # the queue filled up and sends were refused
    assert sum(e["event"] == "sd_notify_failed" for e in logs) >= 1
    assert "BlockingIOError" in next(e for e in logs if e["event"] == "sd_notify_failed")["error"]
    assert recv(sock) == b"STATUS=step 0"
    notifier.close()


@pytest.mark.parametrize(
    ("environ", "expected"),
    [
        ({}, None),
        ({"WATCHDOG_USEC": "5000000"}, 5.0),
        ({"WATCHDOG_USEC": "250000", "WATCHDOG_PID": "4242"}, 0.25),
        ({"WATCHDOG_USEC": "5000000", "WATCHDOG_PID": "4243"}, None),  # someone else's
        ({"WATCHDOG_USEC": "5000000", "WATCHDOG_PID": "x"}, None),
        ({"WATCHDOG_USEC": "0"}, None),
        ({"WATCHDOG_USEC": "-5"}, None),
        ({"WATCHDOG_USEC": "five"}, None),
    ],
)
def test_parse_watchdog_interval(environ: dict[str, str], expected: float | None) -> None:
    assert parse_watchdog_interval_s(environ, pid=4242) == expected


def test_sanitize_status_truncates() -> None:
    text = sanitize_status("x" * 500, max_chars=20)
    assert text == "x" * 17 + "..."
    assert sanitize_status("  a \t b\r\n c ") == "a b c"
