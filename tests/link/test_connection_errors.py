"""Opening the link fails with ONE clear LinkError, never a traceback-worthy exception."""

from __future__ import annotations

import socket
from pathlib import Path

import pytest

from helixd.link.connection import Autopilot
from helixd.mav.url import ALLOWED_FORMS, LinkError, LinkTimeout
from tests.support.peer import free_port, link_config, safety_config, udp_peer


async def connect_error(url: str, **kw: object) -> LinkError:
    with pytest.raises(LinkError) as info:
        await Autopilot.connect(link_config(url=url, **kw), safety_config())
    exc = info.value
    assert exc.__cause__ is None  # no chained traceback to print
    assert exc.__context__ is None or exc.__suppress_context__
    assert "\n" not in str(exc)
    return exc


async def test_missing_serial_device() -> None:
    exc = await connect_error("/dev/ttyFOO")
    assert "/dev/ttyFOO" in str(exc) and "no such device" in str(exc)


async def test_not_a_serial_device() -> None:
    exc = await connect_error("/dev/null:57600")
    assert "/dev/null is not a serial device" in str(exc)


async def test_refused_tcp_port() -> None:
    port = free_port(socket.SOCK_STREAM)  # bound, closed: nothing listens there now
    exc = await connect_error(f"tcp:127.0.0.1:{port}")
    assert f"tcp:127.0.0.1:{port}" in str(exc) and "connection refused" in str(exc)


async def test_garbage_url() -> None:
    # The config refuses it when it loads (tests/unit/test_cli_errors.py); a LinkConfig built
    # without validation still cannot open it.
    with pytest.raises(LinkError) as info:
        cfg = link_config().model_copy(update={"url": "garbage:::"})
        await Autopilot.connect(cfg, safety_config())
    assert "'garbage:::'" in str(info.value) and ALLOWED_FORMS in str(info.value)


async def test_udpin_on_an_address_we_do_not_have() -> None:
    exc = await connect_error("udpin:192.0.2.1:14550")  # TEST-NET-1, never local
    assert "cannot listen on 192.0.2.1:14550" in str(exc)


async def test_unreadable_or_malformed_signing_key(tmp_path: Path) -> None:
    exc = await connect_error("udpin:127.0.0.1:0", signing_key_file=tmp_path / "missing.key")
    assert "missing.key" in str(exc)
    bad = tmp_path / "short.key"
    bad.write_text("abc123")
    exc = await connect_error("udpin:127.0.0.1:0", signing_key_file=bad)
    assert "64 hex characters" in str(exc)


async def test_no_heartbeat_times_out_with_hints() -> None:
    ap = await Autopilot.connect(link_config(), safety_config())
    try:
        with pytest.raises(LinkTimeout, match="nothing received at all"):
            await ap.wait_heartbeat(0.3)
        address = ap.local_address
        assert address is not None
        peer = udp_peer(address, sysid=7)  # an autopilot, but not the one we target
        peer.start()
        try:
            with pytest.raises(LinkTimeout) as info:
                await ap.wait_heartbeat(0.5)
            assert "heard other systems 7" in str(info.value)
            assert "link.target_system" in str(info.value)
        finally:
            peer.stop()
    finally:
        await ap.close()
