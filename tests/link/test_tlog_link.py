"""The link's .tlog: LinkTlog's flush timer, and the codec hook over a real UDP socket (every
frame in — the autopilot's and another system's — and every frame out, read back by pymavlink).
"""

from __future__ import annotations

import asyncio
import os
import socket
from pathlib import Path

os.environ.setdefault("MAVLINK20", "1")
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.config.link import LinkConfig
from helixd.config.safety import SafetyConfig
from helixd.link.connection import Autopilot
from helixd.link.wire.tlog import FLUSH_INTERVAL_S, LinkTlog, TlogWriter, attach_tlog
from tests.support.mavmsgs import read_tlog

T0 = 1_763_900_000.0


def heartbeat(sysid: int) -> bytes:
    mav = mavlink.MAVLink(None, srcSystem=sysid, srcComponent=1)
    return bytes(mavlink.MAVLink_heartbeat_message(10, 3, 0, 0, 4, 3).pack(mav))


class SignallingWriter(TlogWriter):
    def __init__(self, path: Path) -> None:
        super().__init__(path, 1 << 20)
        self.flushed = asyncio.Event()

    def flush(self) -> None:
        super().flush()
        self.flushed.set()


def test_a_buffered_frame_is_flushed_by_a_timer_within_half_a_second(tmp_path: Path) -> None:
    async def main() -> None:
        loop = asyncio.get_running_loop()
        writer = SignallingWriter(tmp_path / "a.tlog")
        tlog = LinkTlog(writer, clock=lambda: T0)
        assert tlog.flush_due is None  # a quiet link arms nothing
        tlog.record(heartbeat(1))
        timer = tlog.flush_due
        assert timer is not None
        assert 0.0 < timer.when() - loop.time() <= min(FLUSH_INTERVAL_S, 0.5)
        tlog.record(heartbeat(1))
        assert tlog.flush_due is timer  # one timer for the whole batch
        await asyncio.wait_for(writer.flushed.wait(), 2.0)
        assert tlog.flush_due is None
        assert (tmp_path / "a.tlog").stat().st_size == 2 * (8 + len(heartbeat(1)))
        tlog.record(b"not a frame")  # refused by the writer: nothing to flush, no timer
        assert tlog.flush_due is None
        tlog.record(heartbeat(2))
        assert tlog.flush_due is not None
        tlog.close()  # flushes what is left and cancels the timer
        assert tlog.flush_due is None
        assert len(read_tlog(tmp_path / "a.tlog")) == 3

    asyncio.run(main())


def test_codec_logs_every_frame_in_and_out(tmp_path: Path) -> None:
    path = tmp_path / "link.tlog"

    async def main() -> None:
        cfg = LinkConfig(url="udpin:127.0.0.1:0")
        ap = await Autopilot.connect(cfg, SafetyConfig())
        tlog = attach_tlog(ap, path, 1 << 20)
        addr = ap.local_address
        assert addr is not None
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as peer:
            peer.sendto(heartbeat(77), addr)  # another system: logged, though ignored
            peer.sendto(heartbeat(1), addr)
            await ap.wait_heartbeat(5.0)
            assert ap.state.foreign_sysid_counts == {77: 1}
            ap.action.send_rc_override([1500] * 8 + [0] * 10)
            out = peer.recv(512)  # what went out is what was logged
            assert out[0] == 0xFD
            await ap.close()
        assert not tlog.writer.active  # closed with the link
        msgs = read_tlog(path)
        got = [(m.get_type(), m.get_srcSystem()) for m in msgs]
        assert got == [("HEARTBEAT", 77), ("HEARTBEAT", 1), ("RC_CHANNELS_OVERRIDE", 247)]
        assert bytes(msgs[2].get_msgbuf()) == out

    asyncio.run(main())
