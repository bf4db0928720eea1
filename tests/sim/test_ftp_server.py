"""The simulator's FTP server (helixd.sim.ftp_server) against ArduPilot's GCS_FTP.cpp semantics.

Requests are built and replies read with helixd.mav.ftp_wire; files live in a real temp directory.
"""

from __future__ import annotations

import errno
import os
import struct
import tempfile
from collections.abc import Iterator
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as hs

from helixd.mav.ftp_wire import FtpErr, FtpOp, FtpPayload, crc32_ardupilot
from helixd.sim.ftp_server import FtpServer

GCS = (255, 190)
OTHER = (254, 190)


def req(
    op: FtpOp | int,
    seq: int = 0,
    session: int = 0,
    data: bytes = b"",
    *,
    offset: int = 0,
    size: int | None = None,
) -> bytes:
    raw = bytearray(
        FtpPayload(
            seq_number=seq,
            session=session,
            opcode=int(op),
            size=len(data),
            offset=offset,
            data=data,
        ).pack()
    )
    if size is not None:
        raw[4] = size  # any size, also one that does not match the data (hostile or a read)
    return bytes(raw)


def call(
    srv: FtpServer, payload: bytes, now_s: float = 0.0, who: tuple[int, int] = GCS
) -> list[FtpPayload]:
    out = srv.handle(payload, sysid=who[0], compid=who[1], now_s=now_s)
    assert all(len(r) == 251 for r in out)
    return [FtpPayload.unpack(r) for r in out]


def one(
    srv: FtpServer, payload: bytes, now_s: float = 0.0, who: tuple[int, int] = GCS
) -> FtpPayload:
    replies = call(srv, payload, now_s, who)
    assert len(replies) == 1, replies
    return replies[0]


def nak(reply: FtpPayload) -> tuple[int, ...]:
    assert reply.opcode == FtpOp.Nack, reply
    return tuple(reply.data)


def ack(reply: FtpPayload) -> FtpPayload:
    assert reply.opcode == FtpOp.Ack, (reply, reply.data)
    return reply


@pytest.fixture
def root(tmp_path: Path) -> Path:
    r = tmp_path / "root"
    r.mkdir()
    return r


@pytest.fixture
def srv(root: Path) -> Iterator[FtpServer]:
    with FtpServer(root) as server:
        yield server


def session(srv: FtpServer, now_s: float = 0.0, who: tuple[int, int] = GCS) -> int:
    """A session id of our own, as a client takes it from a reply: ArduPilot 4.7 gives every
    request with session 0 a new slot, busy for 3 s (five such requests at once exhaust it)."""
    return ack(one(srv, req(FtpOp.None_, 0, 0), now_s, who)).session


def open_write(srv: FtpServer, name: bytes, now_s: float = 0.0, who: tuple[int, int] = GCS) -> int:
    """CreateFile with session 0; returns the session id the reply hands out."""
    r = ack(one(srv, req(FtpOp.CreateFile, 100, 0, name), now_s, who))
    assert r.session != 0
    return r.session


def test_reply_header_answers_the_request(srv: FtpServer) -> None:
    r = one(srv, req(FtpOp.ResetSessions, seq=41, session=9))
    assert (r.opcode, r.req_opcode, r.seq_number, r.session, r.size) == (
        FtpOp.Ack,
        FtpOp.ResetSessions,
        42,
        9,
        0,
    )
    r = one(srv, req(FtpOp.None_, seq=0xFFFF, session=3))
    assert (r.opcode, r.req_opcode, r.seq_number) == (FtpOp.Ack, FtpOp.None_, 0)  # uint16


def test_upload_writes_the_file_in_an_allocated_session(srv: FtpServer, root: Path) -> None:
    (root / "APM").mkdir()
    r = ack(one(srv, req(FtpOp.CreateFile, 1, 0, b"/APM/guard.lua")))
    assert (r.req_opcode, r.seq_number, r.session) == (FtpOp.CreateFile, 2, 1)
    sid = r.session
    for seq, (off, chunk) in enumerate([(0, b"local x = 1\n"), (12, b"return x\n")], start=2):
        w = ack(one(srv, req(FtpOp.WriteFile, seq, sid, chunk, offset=off)))
        assert (w.offset, w.size, w.session, w.seq_number) == (off, 0, sid, seq + 1)
    assert srv.open_files == 1
    ack(one(srv, req(FtpOp.TerminateSession, 4, sid)))
    assert srv.open_files == 0
    assert (root / "APM" / "guard.lua").read_bytes() == b"local x = 1\nreturn x\n"
    # the next session-0 request gets the next id
    assert open_write(srv, b"/second.lua") == 2


@pytest.mark.parametrize(
    ("op", "name"),
    [
        (FtpOp.CreateFile, b"/../outside/evil.lua"),
        (FtpOp.CreateFile, b"APM/../../outside/evil.lua"),
        (FtpOp.CreateFile, b"/link/evil.lua"),  # a symlink under root that leads out
        (FtpOp.OpenFileRO, b"/../outside/secret"),
        (FtpOp.OpenFileRO, b"/link/secret"),
        (FtpOp.CalcFileCRC32, b"../outside/secret"),
        (FtpOp.ListDirectory, b"/.."),
        (FtpOp.CreateDirectory, b"/../outside/d"),
        (FtpOp.RemoveFile, b"/../outside/secret"),
        (FtpOp.RemoveDirectory, b"/"),  # root itself
        (FtpOp.Rename, b"/a.txt\0/../outside/a.txt"),
        (FtpOp.Rename, b"/link/secret\0/stolen"),
    ],
)
def test_path_escapes_are_refused(op: FtpOp, name: bytes, tmp_path: Path) -> None:
    outside = tmp_path / "outside"
    outside.mkdir()
    (outside / "secret").write_bytes(b"s3cret")
    root = tmp_path / "root"
    root.mkdir()
    (root / "a.txt").write_bytes(b"a")
    (root / "link").symlink_to(outside)
    before = sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*"))
    with FtpServer(root) as server:
        assert nak(one(server, req(op, 1, 0, name))) == (FtpErr.FileProtected,)
        assert server.open_files == 0
    assert sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*")) == before
    assert (outside / "secret").read_bytes() == b"s3cret"


def test_a_repeated_request_gets_the_last_reply_again(srv: FtpServer, root: Path) -> None:
    sid = ack(one(srv, req(FtpOp.CreateDirectory, 1, 0, b"/a"))).session
    mkdir_b = req(FtpOp.CreateDirectory, 10, sid, b"/b")
    first = srv.handle(mkdir_b, sysid=GCS[0], compid=GCS[1], now_s=0.1)
    again = srv.handle(mkdir_b, sysid=GCS[0], compid=GCS[1], now_s=0.2)
    assert again == first  # not run twice: a second mkdir would say FileExists
    assert FtpPayload.unpack(first[0]).opcode == FtpOp.Ack
    # a new seq number is a new request
    assert nak(one(srv, req(FtpOp.CreateDirectory, 11, sid, b"/b"))) == (FtpErr.FileExists,)
    # only the last reply is kept: the older request runs again
    assert nak(one(srv, mkdir_b)) == (FtpErr.FileExists,)
    # another sender with the same seq and session is not answered from our reply
    assert nak(one(srv, req(FtpOp.CreateDirectory, 11, sid, b"/b"), who=OTHER)) == (
        FtpErr.FileExists,
    )


def test_an_ack_as_a_request_is_eaten_and_its_repeat_replays_an_unsent_reply(
    srv: FtpServer,
) -> None:
    """ArduPilot's worker sets up the reply before Session::handle_request eats an Ack or Nack
    request, so a repeat of that seq gets the never-sent reply: opcode None (hypothesis found
    it; the simulator keeps ArduPilot's behaviour, a client must ignore such a reply)."""
    sid = ack(one(srv, req(FtpOp.CreateDirectory, 1, 0, b"/a"))).session
    eaten = req(FtpOp.Ack, 4, sid)
    assert srv.handle(eaten, sysid=GCS[0], compid=GCS[1], now_s=0.1) == []
    (replayed,) = srv.handle(eaten, sysid=GCS[0], compid=GCS[1], now_s=0.2)
    r = FtpPayload.unpack(replayed)
    assert (r.opcode, r.req_opcode, r.seq_number) == (FtpOp.None_, FtpOp.Ack, 5)


def test_a_repeated_session_zero_request_runs_again_in_a_new_session(srv: FtpServer) -> None:
    # ArduPilot 4.7 hands session 0 a fresh id, so the repeat no longer matches its reply
    mkdir = req(FtpOp.CreateDirectory, 5, 0, b"/d")
    first = ack(one(srv, mkdir))
    again = one(srv, mkdir)
    assert nak(again) == (FtpErr.FileExists,)
    assert again.session != first.session


def test_session_zero_requests_each_take_a_slot_for_3_s(srv: FtpServer) -> None:
    # GCS_FTP::worker claims a slot for any request whose session matches none; its reply
    # makes the slot busy for FTP_SESSION_TIMEOUT
    for seq in range(5):
        ack(one(srv, req(FtpOp.None_, seq, 0), now_s=0.0))
    assert nak(one(srv, req(FtpOp.None_, 5, 0), now_s=0.5)) == (FtpErr.NoSessionsAvailable,)
    ack(one(srv, req(FtpOp.None_, 6, 0), now_s=3.1))
    # an ACK sent to the server also claims a slot, but gets no reply: the slot stays free
    assert call(srv, req(FtpOp.Ack, 7, 0), now_s=3.2) == []


def test_one_session_at_a_time(root: Path) -> None:
    with FtpServer(root, max_sessions=1) as server:
        sid = open_write(server, b"/a.bin", now_s=0.0)
        b_open = req(FtpOp.CreateFile, 7, 0, b"/b.bin")
        busy = one(server, b_open, now_s=1.0, who=OTHER)
        assert nak(busy) == (FtpErr.NoSessionsAvailable,)
        assert (busy.session, busy.seq_number, busy.req_opcode) == (0, 8, FtpOp.CreateFile)
        ack(one(server, req(FtpOp.WriteFile, 101, sid, b"A", offset=0), now_s=2.5))
        assert nak(one(server, b_open, now_s=5.4, who=OTHER)) == (FtpErr.NoSessionsAvailable,)
        # A has sent nothing for more than 3 s: B takes the slot, A's file is closed;
        # the same request as before is run (NoSessionsAvailable is never replayed)
        b_sid = ack(one(server, b_open, now_s=5.6, who=OTHER)).session
        assert server.open_files == 1
        assert (root / "b.bin").exists()
        assert nak(one(server, req(FtpOp.WriteFile, 102, sid, b"B", offset=1), now_s=5.7)) == (
            FtpErr.NoSessionsAvailable,
        )
        ack(one(server, req(FtpOp.TerminateSession, 8, b_sid), now_s=5.8, who=OTHER))
        # a terminated session is free at once
        assert open_write(server, b"/c.bin", now_s=5.9) != 0
    assert (root / "a.bin").read_bytes() == b"A"


def test_five_sessions_by_default_and_reset_closes_only_the_senders(
    srv: FtpServer, root: Path
) -> None:
    senders = [(200 + i, 1) for i in range(5)]
    sids = [open_write(srv, f"/f{i}".encode(), 0.1 * i, who) for i, who in enumerate(senders)]
    assert len(set(sids)) == 5 and srv.open_files == 5
    assert nak(one(srv, req(FtpOp.CreateFile, 1, 0, b"/f5"), 1.0, GCS)) == (
        FtpErr.NoSessionsAvailable,
    )
    ack(one(srv, req(FtpOp.ResetSessions, 9, 0), 1.1, senders[0]))
    assert srv.open_files == 4
    for i, who in enumerate(senders[1:], start=1):
        ack(one(srv, req(FtpOp.WriteFile, 10, sids[i], b"x"), 1.2, who))
    # the slot freed by the reset is taken at once
    assert open_write(srv, b"/f5", 1.3) != 0


def test_idle_sessions_are_closed_after_20_s(srv: FtpServer) -> None:
    open_write(srv, b"/a", now_s=0.0)
    open_write(srv, b"/b", now_s=0.0, who=OTHER)
    ack(one(srv, req(FtpOp.None_, 1, 50), now_s=20.0))
    assert srv.open_files == 2
    ack(one(srv, req(FtpOp.None_, 2, 50), now_s=20.01))
    assert srv.open_files == 0


def test_read_a_file(srv: FtpServer, root: Path) -> None:
    (root / "hello.txt").write_bytes(b"hello world")
    assert nak(one(srv, req(FtpOp.ReadFile, 1, 0, size=10))) == (FtpErr.FileNotFound,)
    opened = ack(one(srv, req(FtpOp.OpenFileRO, 2, 0, b"/hello.txt")))
    sid = opened.session
    assert opened.size == 4 and struct.unpack("<I", opened.data) == (11,)
    r = ack(one(srv, req(FtpOp.ReadFile, 3, sid, offset=0, size=5)))
    assert (r.data, r.offset) == (b"hello", 0)
    r = ack(one(srv, req(FtpOp.ReadFile, 4, sid, offset=6, size=239)))
    assert (r.data, r.offset) == (b"world", 6)
    assert nak(one(srv, req(FtpOp.ReadFile, 5, sid, offset=11, size=10))) == (FtpErr.EndOfFile,)
    assert nak(one(srv, req(FtpOp.WriteFile, 6, sid, b"x"))) == (FtpErr.Fail,)
    assert nak(one(srv, req(FtpOp.OpenFileRO, 7, sid, b"/hello.txt"))) == (FtpErr.Fail,)
    assert nak(one(srv, req(FtpOp.CreateFile, 8, sid, b"/new"))) == (FtpErr.Fail,)
    # an offset ArduPilot's int32 lseek cannot take
    e = nak(one(srv, req(FtpOp.ReadFile, 9, sid, offset=1 << 31, size=4)))
    assert e == (FtpErr.FailErrno, errno.EINVAL)
    ack(one(srv, req(FtpOp.TerminateSession, 10, sid)))
    assert nak(one(srv, req(FtpOp.ReadFile, 11, sid, size=4))) == (FtpErr.FileNotFound,)


def test_an_idle_read_session_may_open_again(srv: FtpServer, root: Path) -> None:
    (root / "f").write_bytes(b"f")
    sid = ack(one(srv, req(FtpOp.OpenFileRO, 1, 0, b"/f"), now_s=0.0)).session
    assert nak(one(srv, req(FtpOp.OpenFileRO, 2, sid, b"/f"), now_s=3.0)) == (FtpErr.Fail,)
    ack(one(srv, req(FtpOp.OpenFileRO, 3, sid, b"/f"), now_s=6.1))


def test_errors_as_ardupilot_reports_them(srv: FtpServer, root: Path) -> None:
    sid = session(srv)
    (root / "file").write_bytes(b"x")
    (root / "dir").mkdir()
    (root / "dir" / "inner").write_bytes(b"y")
    # ENOENT → FileNotFound and EEXIST → FileExists, one byte; other errno: FailErrno + errno
    assert nak(one(srv, req(FtpOp.OpenFileRO, 1, sid, b"/missing"))) == (FtpErr.FileNotFound,)
    assert nak(one(srv, req(FtpOp.CreateFile, 2, sid, b"/no/dir/x"))) == (FtpErr.FileNotFound,)
    assert nak(one(srv, req(FtpOp.CreateDirectory, 3, sid, b"/dir"))) == (FtpErr.FileExists,)
    assert nak(one(srv, req(FtpOp.CreateFile, 4, sid, b"/file/x"))) == (
        FtpErr.FailErrno,
        errno.ENOTDIR,
    )
    e = nak(one(srv, req(FtpOp.RemoveDirectory, 5, sid, b"/dir")))  # not empty
    assert e[0] == FtpErr.FailErrno and len(e) == 2
    assert nak(one(srv, req(FtpOp.CalcFileCRC32, 6, sid, b"/dir"))) == (
        FtpErr.FailErrno,
        errno.EISDIR,
    )


def test_romfs_is_read_only(srv: FtpServer, root: Path) -> None:
    sid = session(srv)
    (root / "@ROMFS").mkdir()
    (root / "@ROMFS" / "scripts.lua").write_bytes(b"-- rom")
    erofs = (FtpErr.FailErrno, errno.EROFS)
    assert nak(one(srv, req(FtpOp.CreateFile, 1, sid, b"@ROMFS/x.lua"))) == erofs
    assert nak(one(srv, req(FtpOp.OpenFileWO, 2, sid, b"@ROMFS/scripts.lua"))) == erofs
    assert nak(one(srv, req(FtpOp.CreateDirectory, 3, sid, b"@ROMFS/d"))) == erofs
    assert nak(one(srv, req(FtpOp.RemoveFile, 4, sid, b"@ROMFS/scripts.lua"))) == erofs
    assert nak(one(srv, req(FtpOp.Rename, 5, sid, b"@ROMFS/scripts.lua\0/s.lua"))) == erofs
    ack(one(srv, req(FtpOp.OpenFileRO, 6, sid, b"@ROMFS/scripts.lua")))
    assert (root / "@ROMFS" / "scripts.lua").read_bytes() == b"-- rom"


def test_writes_past_the_disk_cap_are_enospc(root: Path) -> None:
    with FtpServer(root, max_file_bytes=100) as server:
        sid = open_write(server, b"/big")
        ack(one(server, req(FtpOp.WriteFile, 1, sid, b"x" * 10, offset=90)))
        assert nak(one(server, req(FtpOp.WriteFile, 2, sid, b"x" * 11, offset=90))) == (
            FtpErr.FailErrno,
            errno.ENOSPC,
        )
    assert (root / "big").stat().st_size == 100


def test_open_file_wo_keeps_the_content_create_file_truncates(srv: FtpServer, root: Path) -> None:
    (root / "f").write_bytes(b"0123456789")
    sid = ack(one(srv, req(FtpOp.OpenFileWO, 1, 0, b"/f"))).session
    ack(one(srv, req(FtpOp.WriteFile, 2, sid, b"ab", offset=2)))
    ack(one(srv, req(FtpOp.TerminateSession, 3, sid)))
    assert (root / "f").read_bytes() == b"01ab456789"
    sid = ack(one(srv, req(FtpOp.CreateFile, 4, sid, b"/f"))).session
    ack(one(srv, req(FtpOp.TerminateSession, 5, sid)))
    assert (root / "f").read_bytes() == b""


def test_name_sizes_follow_check_name_len(srv: FtpServer, root: Path) -> None:
    sid = session(srv)
    raw = bytearray(req(FtpOp.CreateDirectory, 1, sid, b"/d"))
    raw[4] = 240  # size past the data field
    assert nak(one(srv, bytes(raw))) == (FtpErr.InvalidDataSize,)
    assert nak(one(srv, req(FtpOp.CreateDirectory, 2, sid, b"/d", size=1))) == (
        FtpErr.InvalidDataSize,
    )
    assert nak(one(srv, req(FtpOp.CreateDirectory, 3, sid, b"", size=0))) == (
        FtpErr.InvalidDataSize,
    )
    # the size may count the terminating NUL
    ack(one(srv, req(FtpOp.CreateDirectory, 4, sid, b"/d\0")))
    assert (root / "d").is_dir()


def test_unknown_commands(srv: FtpServer) -> None:
    assert nak(one(srv, req(FtpOp.TruncateFile, 1, 0, b"/x"))) == (FtpErr.UnknownCommand,)
    assert nak(one(srv, req(200, 2, 0))) == (FtpErr.UnknownCommand,)
    # an ACK or NAK sent to the server is eaten
    assert call(srv, req(FtpOp.Ack, 3, 0)) == []
    assert call(srv, req(FtpOp.Nack, 4, 0)) == []
    # what MAVLink could not carry is dropped
    assert srv.handle(bytes(252), sysid=1, compid=1, now_s=0.0) == []


def parse_listing(data: bytes) -> list[str]:
    assert data.endswith(b"\0")
    return [e.decode() for e in data[:-1].split(b"\0")]


def test_list_directory_pages_through_every_entry(srv: FtpServer, root: Path) -> None:
    sid = session(srv)
    scripts = root / "APM" / "scripts"
    scripts.mkdir(parents=True)
    expected = set()
    for i in range(30):
        name = f"script_with_a_rather_long_name_{i:02d}.lua"
        (scripts / name).write_bytes(b"x" * i)
        expected.add(f"F{name}\t{i}")
    for d in ("modules", "sub"):
        (scripts / d).mkdir()
        expected.add(f"D{d}")
    got: list[str] = []
    pages = 0
    while True:
        r = one(srv, req(FtpOp.ListDirectory, 10 + pages, sid, b"/APM/scripts/", offset=len(got)))
        if r.opcode == FtpOp.Nack:
            assert nak(r) == (FtpErr.EndOfFile,) and r.offset == len(got)
            break
        assert r.offset == len(got) and r.size <= 239
        got += parse_listing(r.data)
        pages += 1
    assert pages > 1
    assert sorted(got) == sorted(expected)
    assert nak(one(srv, req(FtpOp.ListDirectory, 90, sid, b"/APM/scripts/sub"))) == (
        FtpErr.EndOfFile,
    )
    assert nak(one(srv, req(FtpOp.ListDirectory, 91, sid, b"/nope"))) == (FtpErr.FileNotFound,)
    f = b"/APM/scripts/script_with_a_rather_long_name_00.lua"
    assert nak(one(srv, req(FtpOp.ListDirectory, 92, sid, f))) == (FtpErr.FailErrno, errno.ENOTDIR)
    root_list = parse_listing(ack(one(srv, req(FtpOp.ListDirectory, 93, sid, b"/"))).data)
    assert root_list == ["DAPM"]


def test_crc32_is_ardupilots(srv: FtpServer, root: Path) -> None:
    sid = session(srv)
    content = bytes(range(256)) * 21
    (root / "f.bin").write_bytes(content)
    r = ack(one(srv, req(FtpOp.CalcFileCRC32, 1, sid, b"/f.bin")))
    assert r.size == 4
    # crc_crc32 from 0 (tests/mav/test_ftp_wire.py checks crc32_ardupilot against its transcription)
    assert struct.unpack("<I", r.data) == (crc32_ardupilot(content),) == (0x298D2CE0,)
    (root / "empty").write_bytes(b"")
    r = ack(one(srv, req(FtpOp.CalcFileCRC32, 2, sid, b"/empty")))
    assert r.data == bytes(4)
    assert nak(one(srv, req(FtpOp.CalcFileCRC32, 3, sid, b"/nope"))) == (FtpErr.FileNotFound,)


def test_remove_and_rename(srv: FtpServer, root: Path) -> None:
    sid = session(srv)
    (root / "a").write_bytes(b"a")
    (root / "empty").mkdir()
    ack(one(srv, req(FtpOp.Rename, 1, sid, b"/a\0/b")))
    assert (root / "b").read_bytes() == b"a" and not (root / "a").exists()
    ack(one(srv, req(FtpOp.Rename, 2, sid, b"/b\0/c\0")))  # with the final NUL counted
    assert nak(one(srv, req(FtpOp.Rename, 3, sid, b"/c"))) == (FtpErr.InvalidDataSize,)
    assert nak(one(srv, req(FtpOp.Rename, 4, sid, b"/c\0/d", size=3))) == (FtpErr.InvalidDataSize,)
    assert nak(one(srv, req(FtpOp.Rename, 5, sid, b"/x\0/y"))) == (FtpErr.FileNotFound,)
    # RemoveFile and RemoveDirectory both remove either (rmdir, then unlink)
    ack(one(srv, req(FtpOp.RemoveDirectory, 6, sid, b"/c")))
    ack(one(srv, req(FtpOp.RemoveFile, 7, sid, b"/empty")))
    assert sorted(os.listdir(root)) == []
    assert nak(one(srv, req(FtpOp.RemoveFile, 8, sid, b"/c"))) == (FtpErr.FileNotFound,)


def test_burst_read(srv: FtpServer, root: Path) -> None:
    content = os.urandom(1000)
    (root / "f").write_bytes(content)
    sid = ack(one(srv, req(FtpOp.OpenFileRO, 1, 0, b"/f"))).session
    replies = call(srv, req(FtpOp.BurstReadFile, 10, sid, offset=100, size=0))
    *acks, last = replies
    assert [r.seq_number for r in replies] == list(range(11, 11 + len(replies)))
    assert all(r.opcode == FtpOp.Ack and r.burst_complete == 0 for r in acks)
    assert [r.offset for r in acks] == list(range(100, 1000, 239))
    assert b"".join(r.data for r in acks) == content[100:]
    assert nak(last) == (FtpErr.EndOfFile,)
    assert (last.burst_complete, last.offset, last.req_opcode) == (1, 1000, FtpOp.BurstReadFile)
    small = call(srv, req(FtpOp.BurstReadFile, 40, sid, offset=990, size=4))
    assert [r.data for r in small[:-1]] == [content[990:994], content[994:998], content[998:]]


# --- hostile requests -------------------------------------------------------------------------

NAMES = [b"/", b"..", b"/../x", b"APM", b"/APM/scripts", b"@ROMFS", b"@ROMFS/a", b"a/b", b"f"]
name_bytes = hs.one_of(
    hs.lists(hs.sampled_from([*NAMES, b"/", b"\0", b"."]), max_size=5).map(b"".join),
    hs.binary(max_size=239),
)
opcodes = hs.one_of(hs.sampled_from([int(o) for o in FtpOp]), hs.integers(0, 255))


@hs.composite
def hostile_payload(draw: hs.DrawFn) -> bytes:
    if draw(hs.booleans()):
        return draw(hs.binary(max_size=260))
    data = draw(name_bytes)
    raw = bytearray(
        FtpPayload(
            seq_number=draw(hs.integers(0, 0xFFFF)),
            session=draw(hs.sampled_from([0, 1, 2, 255])),
            opcode=draw(opcodes),
            size=len(data),
            offset=draw(hs.sampled_from([0, 1, 239, 5000, (1 << 31) - 1, 1 << 31, (1 << 32) - 1])),
            data=data,
        ).pack()
    )
    raw[4] = draw(hs.one_of(hs.just(len(data)), hs.integers(0, 255)))
    return bytes(raw)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    hs.lists(
        hs.tuples(hostile_payload(), hs.sampled_from([(1, 1), GCS]), hs.floats(0, 30)),
        min_size=1,
        max_size=12,
    )
)
def test_hostile_requests_never_break_the_server_or_leave_root(
    steps: list[tuple[bytes, tuple[int, int], float]],
) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        base = Path(tmp)
        (base / "outside").mkdir()
        (base / "outside" / "keep").write_bytes(b"k")
        root = base / "root"
        (root / "@ROMFS").mkdir(parents=True)
        (root / "f").write_bytes(b"0123456789" * 30)
        (root / "link").symlink_to(base / "outside")
        with FtpServer(root, max_sessions=2, max_file_bytes=4096) as server:
            sent: set[int] = set()
            for payload, who, now_s in sorted(steps, key=lambda s: s[2]):
                sent.add(payload.ljust(12, b"\0")[3])
                out = server.handle(payload, sysid=who[0], compid=who[1], now_s=now_s)
                for raw in out:
                    r = FtpPayload.unpack(raw)
                    # an Ack or Nack as a request is eaten without a reply (Session::
                    # handle_request), but GCS_FTP::worker has already set up its reply, with
                    # opcode None: a repeat of that request's seq replays it, as ArduPilot does
                    eaten = r.req_opcode in (FtpOp.Ack, FtpOp.Nack)
                    assert r.opcode in (FtpOp.Ack, FtpOp.Nack) or (
                        eaten and r.opcode == FtpOp.None_
                    )
                    # the answer to this request, or (a replay matches on sender, session and
                    # seq only, as in ArduPilot) the last reply to an earlier one
                    assert r.req_opcode in sent
        assert sorted(p.name for p in base.iterdir()) == ["outside", "root"]
        assert [p.name for p in (base / "outside").iterdir()] == ["keep"]
        assert (base / "outside" / "keep").read_bytes() == b"k"
