"""MAVLink 2 signing with link.signing_key_file."""

from __future__ import annotations

from pathlib import Path

import pytest

from helixd.link.connection import Autopilot
from helixd.mav.url import LinkTimeout
from tests.support.peer import link_config, linked, safety_config, udp_peer, until

KEY = bytes(range(32))


async def test_signed_link_works_both_ways(tmp_path: Path) -> None:
    key_file = tmp_path / "helix.key"
    key_file.write_text(KEY.hex() + "\n")
    async with linked(signing_key_file=key_file, peer_kwargs={"signing_key": KEY}) as (ap, peer):
        assert await ap.param.get("RC_OVERRIDE_TIME") == 3.0
        await until(lambda: peer.records.signed_rx >= 1, 2.0, "signed messages at the peer")
        assert peer.records.unsigned_rx == 0


async def test_unsigned_autopilot_is_rejected(tmp_path: Path) -> None:
    key_file = tmp_path / "helix.key"
    key_file.write_bytes(KEY)  # raw 32 bytes work too
    ap = await Autopilot.connect(link_config(signing_key_file=key_file), safety_config())
    address = ap.local_address
    assert address is not None
    peer = udp_peer(address)  # no key: sends unsigned
    peer.start()
    try:
        with pytest.raises(LinkTimeout, match="failed the signing check"):
            await ap.wait_heartbeat(0.6)
        assert ap.state.heartbeat_count == 0
    finally:
        peer.stop()
        await ap.close()
