"""Transports: non-blocking byte pipes (UDP socket, TCP socket, serial device) watched by the
event loop with ``loop.add_reader``.

Reading never blocks the event loop: the reader callback drains the descriptor until it would
block and hands each read to the codec in the loop thread (no thread hand-over, no extra
wake-up). Writes never block either: UDP ``sendto`` on a non-blocking socket (a full buffer
drops the datagram, as the network would), TCP/serial through a bounded write buffer flushed
with ``loop.add_writer``.
"""

from __future__ import annotations

import asyncio
import ipaddress
import os
import socket
import termios
from abc import ABC, abstractmethod
from collections.abc import Callable

import structlog

from helixd.base.clock import now_s
from helixd.config.link import LinkConfig
from helixd.mav.url import LinkError, LinkUrl

log = structlog.get_logger(__name__)

Address = tuple[str, int]
OnData = Callable[[bytes, Address | None, float], None]
OnLost = Callable[[str], None]

READ_CHUNK_BYTES = 65536
MAX_READS_PER_WAKEUP = 64  # bounds one reader callback under a flood
WRITE_BUFFER_MAX_BYTES = 65536  # stream transports: beyond this, new messages are dropped


class Transport(ABC):
    """A non-blocking byte pipe watched by the event loop."""

    def __init__(self, url: LinkUrl, cfg: LinkConfig, on_data: OnData, on_lost: OnLost):
        self.url = url
        self.cfg = cfg
        self._on_data = on_data
        self._on_lost = on_lost

    @abstractmethod
    async def open(self) -> None:
        """Open (or reopen); LinkError with a human message on failure."""

    @abstractmethod
    def write(self, data: bytes) -> bool:
        """Queue ``data``; never blocks, never raises. False when it had to be dropped."""

    @abstractmethod
    def close(self) -> None: ...

    @property
    @abstractmethod
    def is_open(self) -> bool: ...

    @property
    def local_address(self) -> Address | None:
        return None

    def note_peer(self, addr: Address) -> None:  # noqa: B027 - only UDP needs it
        """A datagram from ``addr`` carried the autopilot's messages (UDP only)."""


class UdpTransport(Transport):
    def __init__(self, url: LinkUrl, cfg: LinkConfig, on_data: OnData, on_lost: OnLost):
        super().__init__(url, cfg, on_data, on_lost)
        self._sock: socket.socket | None = None
        self._remote: Address | None = None

    @property
    def is_open(self) -> bool:
        return self._sock is not None

    @property
    def local_address(self) -> Address | None:
        if self._sock is None:
            return None
        host, port = self._sock.getsockname()[:2]
        return str(host), int(port)

    async def open(self) -> None:
        loop = asyncio.get_running_loop()
        url = self.url
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            if url.kind == "udpin":
                sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
                sock.bind((url.host, url.port))
            else:
                self._remote = await _resolved(loop, url.host, url.port)
            sock.setblocking(False)
        except OSError as exc:
            sock.close()
            what = "listen on" if url.kind == "udpin" else "resolve"
            raise LinkError(
                f"{url.text}: cannot {what} {url.host}:{url.port}: {exc.strerror or exc}"
            ) from None
        except BaseException:
            sock.close()
            raise
        self._sock = sock
        loop.add_reader(sock.fileno(), self._readable)

    def note_peer(self, addr: Address) -> None:
        if self.url.kind == "udpin" and addr != self._remote:
            log.info("udp_peer", address=f"{addr[0]}:{addr[1]}")
            self._remote = addr

    def _readable(self) -> None:
        sock = self._sock
        if sock is None:
            return
        for _ in range(MAX_READS_PER_WAKEUP):
            try:
                data, addr = sock.recvfrom(READ_CHUNK_BYTES)
            except BlockingIOError:
                return
            except ConnectionRefusedError:
                continue  # ICMP "port unreachable" for an earlier sendto: the peer is away
            except OSError as exc:
                log.warning("udp_read_error", error=str(exc))
                return
            self._on_data(data, addr, now_s())  # AF_INET: (host str, port int)

    def write(self, data: bytes) -> bool:
        if self._sock is None or self._remote is None:
            return False
        try:
            self._sock.sendto(data, self._remote)
        except OSError:
            return False  # EAGAIN, ECONNREFUSED, ENETUNREACH: UDP is lossy anyway
        return True

    def close(self) -> None:
        if self._sock is not None:
            asyncio.get_running_loop().remove_reader(self._sock.fileno())
            self._sock.close()
            self._sock = None


class FdStreamTransport(Transport):
    """Byte stream on a non-blocking fd (TCP socket or serial device) with a write buffer."""

    def __init__(self, url: LinkUrl, cfg: LinkConfig, on_data: OnData, on_lost: OnLost):
        super().__init__(url, cfg, on_data, on_lost)
        self._fd: int | None = None
        self._wbuf = bytearray()

    @property
    def is_open(self) -> bool:
        return self._fd is not None

    def _attach(self, fd: int) -> None:
        self._fd = fd
        self._wbuf.clear()
        asyncio.get_running_loop().add_reader(fd, self._readable)

    def _release_fd(self, fd: int) -> None:
        os.close(fd)

    def _detach(self) -> None:
        fd = self._fd
        if fd is None:
            return
        loop = asyncio.get_running_loop()
        loop.remove_reader(fd)
        loop.remove_writer(fd)
        self._fd = None
        self._wbuf.clear()
        self._release_fd(fd)

    def _fail(self, reason: str) -> None:
        if self._fd is None:
            return
        self._detach()
        self._on_lost(reason)

    def _readable(self) -> None:
        for _ in range(MAX_READS_PER_WAKEUP):
            fd = self._fd
            if fd is None:
                return
            try:
                data = os.read(fd, READ_CHUNK_BYTES)
            except BlockingIOError:
                return
            except OSError as exc:
                self._fail(f"read error: {exc.strerror or exc}")
                return
            if not data:
                self._fail("closed by the other end")
                return
            self._on_data(data, None, now_s())

    def write(self, data: bytes) -> bool:
        fd = self._fd
        if fd is None:
            return False
        if self._wbuf:
            if len(self._wbuf) + len(data) > WRITE_BUFFER_MAX_BYTES:
                return False
            self._wbuf += data
            return True
        try:
            n = os.write(fd, data)
        except BlockingIOError:
            n = 0
        except OSError as exc:
            self._fail(f"write error: {exc.strerror or exc}")
            return False
        if n < len(data):
            self._wbuf += data[n:]
            asyncio.get_running_loop().add_writer(fd, self._writable)
        return True

    def _writable(self) -> None:
        fd = self._fd
        if fd is None:
            return
        try:
            n = os.write(fd, self._wbuf)
        except BlockingIOError:
            return
        except OSError as exc:
            self._fail(f"write error: {exc.strerror or exc}")
            return
        del self._wbuf[:n]
        if not self._wbuf:
            asyncio.get_running_loop().remove_writer(fd)

    def close(self) -> None:
        self._detach()


class TcpTransport(FdStreamTransport):
    def __init__(self, url: LinkUrl, cfg: LinkConfig, on_data: OnData, on_lost: OnLost):
        super().__init__(url, cfg, on_data, on_lost)
        self._sock: socket.socket | None = None

    async def open(self) -> None:
        loop = asyncio.get_running_loop()
        url = self.url
        where = f"{url.host}:{url.port}"
        sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        sock.setblocking(False)
        try:
            async with asyncio.timeout(self.cfg.tcp_connect_timeout_s):
                infos = await loop.getaddrinfo(
                    url.host, url.port, family=socket.AF_INET, type=socket.SOCK_STREAM
                )
                await loop.sock_connect(sock, infos[0][4])
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        except ConnectionRefusedError:
            sock.close()
            raise LinkError(
                f"{url.text}: connection refused: nothing listens on {where} "
                f"(is SITL / mavlink-router running, and is the port right?)"
            ) from None
        except TimeoutError:
            sock.close()
            raise LinkError(
                f"{url.text}: no answer from {where} within {self.cfg.tcp_connect_timeout_s} s"
            ) from None
        except OSError as exc:
            sock.close()
            raise LinkError(
                f"{url.text}: cannot connect to {where}: {exc.strerror or exc}"
            ) from None
        except BaseException:
            sock.close()
            raise
        self._sock = sock
        self._attach(sock.fileno())

    def _release_fd(self, fd: int) -> None:
        if self._sock is not None:
            self._sock.close()
            self._sock = None


class SerialTransport(FdStreamTransport):
    async def open(self) -> None:
        url = self.url
        dev = url.device
        try:
            fd = os.open(dev, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
        except FileNotFoundError:
            raise LinkError(
                f"{url.text}: no such device {dev} (is the autopilot plugged in? "
                f"see ls /dev/serial/by-id/)"
            ) from None
        except PermissionError:
            raise LinkError(
                f"{url.text}: permission denied on {dev} (add the user to the 'dialout' group)"
            ) from None
        except OSError as exc:
            raise LinkError(f"{url.text}: cannot open {dev}: {exc.strerror or exc}") from None
        try:
            _configure_serial(fd, url.baud)
        except termios.error:
            os.close(fd)
            raise LinkError(f"{url.text}: {dev} is not a serial device") from None
        self._attach(fd)


def _configure_serial(fd: int, baud: int) -> None:
    """Raw 8N1, no flow control, at ``baud`` (the fd is already O_NONBLOCK)."""
    speed = getattr(termios, f"B{baud}")
    attrs = termios.tcgetattr(fd)
    attrs[0] = 0  # iflag: no break/parity/CR translation, no XON/XOFF
    attrs[1] = 0  # oflag: raw output
    attrs[2] = termios.CS8 | termios.CREAD | termios.CLOCAL
    attrs[3] = 0  # lflag: no echo, no canonical mode, no signals
    attrs[4] = speed
    attrs[5] = speed
    # VMIN 1 + O_NONBLOCK: an empty tty reads EAGAIN, so a 0-byte read really is a hang-up
    # (with VMIN 0 Linux returns 0 bytes for "nothing yet" and EOF could not be told apart).
    attrs[6][termios.VMIN] = 1
    attrs[6][termios.VTIME] = 0
    termios.tcsetattr(fd, termios.TCSANOW, attrs)


def make_transport(url: LinkUrl, cfg: LinkConfig, on_data: OnData, on_lost: OnLost) -> Transport:
    if url.kind in ("udpin", "udpout"):
        return UdpTransport(url, cfg, on_data, on_lost)
    if url.kind == "tcp":
        return TcpTransport(url, cfg, on_data, on_lost)
    return SerialTransport(url, cfg, on_data, on_lost)


async def _resolved(loop: asyncio.AbstractEventLoop, host: str, port: int) -> tuple[str, int]:
    """(IPv4 address, port) of ``host``: an address as it is, a name through the resolver
    (off the loop: a name lookup may take seconds)."""
    try:
        ipaddress.IPv4Address(host)
    except ValueError:
        infos = await loop.getaddrinfo(host, port, family=socket.AF_INET, type=socket.SOCK_DGRAM)
        return str(infos[0][4][0]), int(infos[0][4][1])
    return host, port
