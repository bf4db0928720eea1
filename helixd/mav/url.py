"""Connection strings as MAVProxy/pymavlink users write them (pure: no sockets, no files).

Accepted forms::

    /dev/ttyACM0               serial device, baud from ``link.baud``
    /dev/serial0:921600        serial device with its baud (``,921600`` also accepted); what
                               follows the last ':' or ',' must be a standard baud, except in
                               the colon-laden /dev/serial/by-path/ names
    udpin:0.0.0.0:14550        listen for the autopilot (``udp:`` means the same, as in pymavlink)
    udpout:192.168.1.10:14550  send to the autopilot first
    tcp:127.0.0.1:5760         connect to a TCP server (ArduPilot SITL serves 5760)
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Literal

LinkKind = Literal["serial", "udpin", "udpout", "tcp"]

ALLOWED_FORMS = (
    "/dev/ttyACM0, /dev/serial0:921600, udpin:0.0.0.0:14550, udp:0.0.0.0:14550, "
    "udpout:HOST:PORT, tcp:HOST:PORT"
)

MIN_BAUD = 1200
MAX_BAUD_DIGITS = 7
# udev's names by port; they contain colons (…-usb-0:1.4:1.0) that are no baud separator
BY_PATH_DIR = "/dev/serial/by-path/"
# Rates every Linux serial driver accepts through termios (B1200 .. B4000000).
STANDARD_BAUDS = (
    1200,
    1800,
    2400,
    4800,
    9600,
    19200,
    38400,
    57600,
    115200,
    230400,
    460800,
    500000,
    576000,
    921600,
    1000000,
    1152000,
    1500000,
    2000000,
    2500000,
    3000000,
    3500000,
    4000000,
)

_HOST_RE = re.compile(r"^[A-Za-z0-9]([A-Za-z0-9.\-]*[A-Za-z0-9])?$")


class LinkError(Exception):
    """The link to the autopilot could not be opened or used. The message is for humans."""


class LinkTimeout(LinkError):
    """Nothing (or not the expected message) arrived from the autopilot in time."""


@dataclass(frozen=True, slots=True)
class LinkUrl:
    kind: LinkKind
    text: str  # the string as the user wrote it
    host: str = ""
    port: int = 0
    device: str = ""
    baud: int = 0

    def describe(self) -> str:
        if self.kind == "serial":
            return f"serial {self.device} at {self.baud} baud"
        return f"{self.kind} {self.host}:{self.port}"


MAX_SHOWN_CHARS = 80  # a pasted megabyte must not come back as a megabyte of error message


def _shown(text: str) -> str:
    shown = repr(text)
    if len(shown) > MAX_SHOWN_CHARS:
        shown = f"{shown[: MAX_SHOWN_CHARS - 1]}… ({len(text)} characters)"
    return shown


def _bad(url: str, why: str) -> LinkError:
    return LinkError(f"link url {_shown(url)}: {why} (allowed forms: {ALLOWED_FORMS})")


def _host_port(url: str, rest: str, *, allow_port_zero: bool) -> tuple[str, int]:
    host, sep, port_text = rest.rpartition(":")
    if not sep or not host:
        raise _bad(url, "expected HOST:PORT after the scheme")
    if not _HOST_RE.match(host):
        raise _bad(url, f"{_shown(host)} is not a host name or IPv4 address")
    if not port_text.isascii() or not port_text.isdigit() or len(port_text) > 5:
        raise _bad(url, f"port {_shown(port_text)} is not a number in 0..65535")
    port = int(port_text)
    low = 0 if allow_port_zero else 1
    if not low <= port <= 65535:
        raise _bad(url, f"port {port} is outside {low}..65535")
    return host, port


def parse_link_url(url: str, default_baud: int) -> LinkUrl:
    """Parse ``url``; raise :class:`LinkError` naming the url and the allowed forms."""
    text = url.strip()
    if not text:
        raise _bad(url, "empty")
    scheme, sep, rest = text.partition(":")
    if sep and not text.startswith("/"):
        if scheme in ("udpin", "udp"):
            host, port = _host_port(url, rest, allow_port_zero=True)
            return LinkUrl("udpin", text, host=host, port=port)
        if scheme == "udpout":
            host, port = _host_port(url, rest, allow_port_zero=False)
            return LinkUrl("udpout", text, host=host, port=port)
        if scheme == "tcp":
            host, port = _host_port(url, rest, allow_port_zero=False)
            return LinkUrl("tcp", text, host=host, port=port)
        raise _bad(url, f"unknown scheme {_shown(scheme)}")
    if not text.startswith("/"):
        raise _bad(url, "a serial device must be an absolute path such as /dev/ttyACM0")
    device, baud = text, default_baud
    head, sep, tail = text.rpartition(",")
    if not sep:
        head, sep, tail = text.rpartition(":")
    # "/dev/serial/by-path/pci-0000:00:14.0-usb-0:1.0" has colons of its own: there, a
    # trailing part that is no baud (< 1200, or not a number) belongs to the name. Anywhere
    # else what follows the last ',' or ':' is the baud, and must be one.
    by_path = text.startswith(BY_PATH_DIR)
    if sep and head:
        number = tail.isascii() and tail.isdigit() and len(tail) <= MAX_BAUD_DIGITS
        if number and (int(tail) >= MIN_BAUD or not by_path or sep == ","):
            device, baud = head, int(tail)
        elif not by_path or sep == ",":
            raise _bad(url, f"baud {_shown(tail)} is not a number such as 921600")
    if baud not in STANDARD_BAUDS:
        allowed = ", ".join(str(b) for b in STANDARD_BAUDS)
        raise _bad(url, f"baud {baud} is not a standard serial rate ({allowed})")
    return LinkUrl("serial", text, device=device, baud=baud)


def heartbeat_wait_text(url: str, default_baud: int) -> str:
    """What a wait for the autopilot's first HEARTBEAT says (pure): the link it listens on
    (``link.url``) and what to check there."""
    try:
        link = parse_link_url(url, default_baud)
    except LinkError:
        return f"waiting for the autopilot's HEARTBEAT on {url} (link.url)"
    head = f"waiting for the autopilot's HEARTBEAT on {url} (link.url, {link.describe()})"
    if link.kind == "serial":
        return (
            f"{head}: check the autopilot is powered and cabled to {link.device}, its port's "
            f"SERIALn_PROTOCOL = 2 (MAVLink2) and SERIALn_BAUD = {link.baud} (a USB port ignores "
            "the baud)"
        )
    if link.kind == "udpin":
        return (
            f"{head}: it only listens — something must send MAVLink to UDP port {link.port} "
            "(a router, a telemetry bridge, SITL); an autopilot on a serial cable needs "
            "link.url = its device (/dev/serial/by-id/…) in the config"
        )
    return f"{head}: check that {link.host}:{link.port} is the autopilot or its router, and is up"
