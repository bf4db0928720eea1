"""Connection strings as MAVProxy/pymavlink users write them, and the one-line errors."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from helixd.mav.url import (
    ALLOWED_FORMS,
    STANDARD_BAUDS,
    LinkError,
    heartbeat_wait_text,
    parse_link_url,
)


@pytest.mark.parametrize(
    ("url", "kind", "host", "port"),
    [
        ("udpin:0.0.0.0:14550", "udpin", "0.0.0.0", 14550),
        ("udp:0.0.0.0:14550", "udpin", "0.0.0.0", 14550),
        ("udpin:127.0.0.1:0", "udpin", "127.0.0.1", 0),
        ("udpout:192.168.1.10:14550", "udpout", "192.168.1.10", 14550),
        ("tcp:127.0.0.1:5760", "tcp", "127.0.0.1", 5760),
        ("tcp:sitl-host.local:5760", "tcp", "sitl-host.local", 5760),
        ("  tcp:localhost:5762 ", "tcp", "localhost", 5762),
    ],
)
def test_network_urls(url: str, kind: str, host: str, port: int) -> None:
    parsed = parse_link_url(url, 115200)
    assert (parsed.kind, parsed.host, parsed.port) == (kind, host, port)


@pytest.mark.parametrize(
    ("url", "device", "baud"),
    [
        ("/dev/ttyACM0", "/dev/ttyACM0", 57600),
        ("/dev/serial0:921600", "/dev/serial0", 921600),
        ("/dev/ttyUSB0,115200", "/dev/ttyUSB0", 115200),
        (
            "/dev/serial/by-id/usb-ArduPilot_CubeBlack_2E0023-if00",
            "/dev/serial/by-id/usb-ArduPilot_CubeBlack_2E0023-if00",
            57600,
        ),
        # by-path names carry colons of their own; a small trailing number is not a baud
        (
            "/dev/serial/by-path/pci-0000:00:14.0-usb-0:1",
            "/dev/serial/by-path/pci-0000:00:14.0-usb-0:1",
            57600,
        ),
        (
            "/dev/serial/by-path/pci-0000:00:14.0-usb-0:1:115200",
            "/dev/serial/by-path/pci-0000:00:14.0-usb-0:1",
            115200,
        ),
        (
            "/dev/serial/by-path/platform-xhci-hcd.1-usb-0:1.4:1.0",
            "/dev/serial/by-path/platform-xhci-hcd.1-usb-0:1.4:1.0",
            57600,
        ),
        (
            "/dev/serial/by-path/platform-xhci-hcd.1-usb-0:1.4:1.0,921600",
            "/dev/serial/by-path/platform-xhci-hcd.1-usb-0:1.4:1.0",
            921600,
        ),
    ],
)
def test_serial_urls(url: str, device: str, baud: int) -> None:
    parsed = parse_link_url(url, 57600)
    assert (parsed.kind, parsed.device, parsed.baud) == ("serial", device, baud)
    assert "baud" in parsed.describe()


@pytest.mark.parametrize(
    ("url", "reason"),
    [
        ("", "empty"),
        ("garbage", "absolute path"),
        ("COM3", "absolute path"),
        ("ftp:host:21", "unknown scheme 'ftp'"),
        ("tcp:localhost", "HOST:PORT"),
        ("tcp::5760", "HOST:PORT"),
        ("tcp:localhost:http", "port 'http' is not a number"),
        ("tcp:localhost:70000", "outside 1..65535"),
        ("udpout:10.0.0.1:0", "outside 1..65535"),
        ("udpin:bad host:14550", "not a host name"),
        ("/dev/ttyACM0:12345", "not a standard serial rate"),
        # regression: what follows ':' or ',' is a baud, never silently part of the device name
        ("/dev/ttyACM0:abc", "baud 'abc' is not a number"),
        ("/dev/ttyUSB0,fast", "baud 'fast' is not a number"),
        ("/dev/ttyACM0:", "baud '' is not a number"),
        ("/dev/ttyACM0:115", "baud 115 is not a standard serial rate"),
        ("/dev/ttyACM0:١١٥٢٠٠", "is not a number"),
        ("/dev/serial/by-path/pci-0000:00:14.0-usb-0:1,x", "baud 'x' is not a number"),
        # the hostile forms, each exit 2 from the CLI (tests/unit/test_cli_errors.py)
        ("foo", "absolute path"),
        ("tcp:", "HOST:PORT"),
        ("tcp:host:99999", "outside 1..65535"),
        ("http://192.168.1.10:14550", "unknown scheme 'http'"),
        ("   ", "empty"),
        ("tcp:host:١٢٣", "is not a number"),  # Arabic-Indic digits pass str.isdigit()
        ("tcp:host:" + "9" * 5000, "is not a number"),
    ],
)
def test_bad_urls_give_one_clear_message(url: str, reason: str) -> None:
    with pytest.raises(LinkError) as info:
        parse_link_url(url, 115200)
    text = str(info.value)
    assert reason in text
    assert repr(url)[:60] in text  # names the url as written
    assert ALLOWED_FORMS in text  # and what is allowed
    assert "\n" not in text
    assert len(text) < 400


def test_a_huge_url_gives_a_short_message() -> None:
    with pytest.raises(LinkError) as info:
        parse_link_url("x" * 1_000_000, 115200)
    assert len(str(info.value)) < 400 and "1000000 characters" in str(info.value)


def test_default_baud_must_be_standard() -> None:
    with pytest.raises(LinkError, match="not a standard serial rate"):
        parse_link_url("/dev/ttyACM0", 12345)


@given(st.text(max_size=60))
def test_any_text_parses_or_raises_link_error(text: str) -> None:
    try:
        parsed = parse_link_url(text, 115200)
    except LinkError as exc:
        assert str(exc)
        return
    assert parsed.kind in ("serial", "udpin", "udpout", "tcp")
    if parsed.kind == "serial":
        assert parsed.baud in STANDARD_BAUDS
    else:
        assert 0 <= parsed.port <= 65535


def test_the_heartbeat_wait_names_a_serial_link_and_what_to_check() -> None:
    text = heartbeat_wait_text("/dev/serial0:921600", 115200)
    assert text.startswith(
        "waiting for the autopilot's HEARTBEAT on /dev/serial0:921600 (link.url, serial "
        "/dev/serial0 at 921600 baud): check the autopilot is powered and cabled to /dev/serial0"
    )
    assert "SERIALn_PROTOCOL = 2" in text and "SERIALn_BAUD = 921600" in text


def test_the_heartbeat_wait_on_the_installed_udpin_default_says_it_only_listens() -> None:
    """Before: installed, helixd listened on udpin:0.0.0.0:14550 and said only "waiting for
    the autopilot's HEARTBEAT"; the crew's autopilot was on a serial cable."""
    text = heartbeat_wait_text("udpin:0.0.0.0:14550", 115200)
    assert "on udpin:0.0.0.0:14550 (link.url" in text
    assert "it only listens" in text and "link.url = its device" in text


def test_the_heartbeat_wait_on_tcp_names_host_and_port() -> None:
    assert heartbeat_wait_text("tcp:10.0.0.2:5760", 115200).endswith(
        "check that 10.0.0.2:5760 is the autopilot or its router, and is up"
    )
