"""The sans-IO FTP upload client (helixd.link.services.ftp_transfer) against the simulator's FTP
server.

No sockets: request and reply payloads travel between helixd.link.services.ftp_transfer.FtpUpload
and helixd.sim.ftp_server.FtpServer (over a real temp directory) through a channel that can drop,
duplicate and (replies only) delay each one, under hypothesis; time is a simulated clock.
"""

from __future__ import annotations

import asyncio
import errno
import random
import struct
import tempfile
from collections import deque
from collections.abc import Callable
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as hs

from helixd.link.services.ftp_transfer import DirectoryProbe, FtpTransferError, FtpUpload, run_ftp
from helixd.mav.ftp_wire import MAX_DATA_LEN, FtpErr, FtpOp, FtpPayload, crc32_ardupilot
from helixd.sim.ftp_server import FtpServer

GCS = (255, 190)
OTHER = (254, 190)
GUARD = "/APM/scripts/helixd-guard.lua"
DELIVER, DROP, DUPLICATE, DELAY = 0, 1, 2, 3
LATE_S = 0.7  # longer than the client's 0.5 s reply timeout


FIVE_KB_CRC32 = 0x09EACEAD  # crc_crc32 (AP_Math/crc.cpp) from 0 over five_kb()


def five_kb() -> bytes:
    return random.Random(25).randbytes(5 * 1024)


class Channel:
    """Client ⇄ server with a fate per payload (in order of sending, both directions):
    deliver, drop, duplicate, or (replies) deliver ``LATE_S`` late, after a re-send."""

    def __init__(
        self,
        srv: FtpServer,
        fates: list[int] | None = None,
        who: tuple[int, int] = GCS,
        tamper: Callable[[FtpPayload], FtpPayload] | None = None,
    ) -> None:
        self.srv = srv
        self.fates = deque(fates or [])
        self.who = who
        self.tamper = tamper
        self.to_vehicle: deque[bytes] = deque()
        self.to_gcs: deque[bytes] = deque()
        self.late: list[tuple[float, bytes]] = []
        self.vehicle_saw: list[FtpPayload] = []
        self.now_s = 0.0

    def _queue(self, q: deque[bytes], payload: bytes, reply: bool) -> None:
        fate = self.fates.popleft() if self.fates else DELIVER
        if fate == DELAY and reply:
            self.late.append((self.now_s + LATE_S, payload))
            return
        if fate != DROP:
            q.append(payload)
        if fate == DUPLICATE:
            q.append(payload)

    def _to_vehicle(self, payloads: list[bytes]) -> None:
        for p in payloads:
            self._queue(self.to_vehicle, p, reply=False)

    def _deliver_requests(self) -> None:
        while self.to_vehicle:
            p = self.to_vehicle.popleft()
            self.vehicle_saw.append(FtpPayload.unpack(p))
            for r in self.srv.handle(p, sysid=self.who[0], compid=self.who[1], now_s=self.now_s):
                if self.tamper is not None:
                    r = self.tamper(FtpPayload.unpack(r)).pack()
                self._queue(self.to_gcs, r, reply=True)

    def run(self, up: FtpUpload, step_s: float = 0.05, limit_s: float = 600.0) -> FtpUpload:
        self._to_vehicle(up.start(self.now_s))
        while not up.done and self.now_s < limit_s:
            self._deliver_requests()
            self.to_gcs.extend(p for due, p in self.late if due <= self.now_s)
            self.late = [(due, p) for due, p in self.late if due > self.now_s]
            while self.to_gcs:
                self._to_vehicle(up.on_reply(self.to_gcs.popleft(), self.now_s))
            self.now_s += step_s
            self._to_vehicle(up.on_time(self.now_s))
        self._deliver_requests()  # what the client sent last (a release after a failure)
        return up

    def ops(self) -> list[FtpOp]:
        return [FtpOp(p.opcode) for p in self.vehicle_saw]


@pytest.fixture
def root(tmp_path: Path) -> Path:
    return tmp_path


def test_upload_of_5_kB_makes_the_directories_and_verifies_the_crc(root: Path) -> None:
    data = five_kb()
    with FtpServer(root) as srv:
        ch = Channel(srv)
        up = ch.run(FtpUpload(GUARD, data))
        assert up.error is None and up.done
        assert srv.open_files == 0
    assert (root / "APM" / "scripts" / "helixd-guard.lua").read_bytes() == data
    assert up.remote_crc32 == up.local_crc32 == FIVE_KB_CRC32
    writes = [p for p in ch.vehicle_saw if p.opcode == FtpOp.WriteFile]
    n = len(writes)
    assert ch.ops() == [
        FtpOp.ResetSessions,
        FtpOp.CreateFile,  # FileNotFound: /APM/scripts is missing
        FtpOp.CreateDirectory,
        FtpOp.CreateDirectory,
        FtpOp.CreateFile,
        *[FtpOp.WriteFile] * n,
        FtpOp.TerminateSession,
        FtpOp.CalcFileCRC32,
        FtpOp.TerminateSession,
    ]
    assert [p.data for p in ch.vehicle_saw if p.opcode == FtpOp.CreateDirectory] == [
        b"/APM",
        b"/APM/scripts",
    ]
    assert n == -(-len(data) // MAX_DATA_LEN)
    assert all(p.size == len(p.data) <= MAX_DATA_LEN for p in writes)
    assert [p.offset for p in writes] == list(range(0, len(data), MAX_DATA_LEN))
    assert b"".join(p.data for p in writes) == data
    # sequence numbers count up one per request, all in the client's own session
    assert [p.seq_number for p in ch.vehicle_saw] == list(range(len(ch.vehicle_saw)))
    assert {p.session for p in ch.vehicle_saw} == {1}
    assert up.bytes_acked == len(data) and up.resends == 0


def test_with_session_zero_the_client_follows_the_id_ardupilot_assigns(root: Path) -> None:
    (root / "APM" / "scripts").mkdir(parents=True)
    with FtpServer(root) as srv:
        srv.handle(FtpPayload(0, 0, FtpOp.None_).pack(), sysid=9, compid=9, now_s=0.0)  # id 1
        ch = Channel(srv)
        up = ch.run(FtpUpload(GUARD, five_kb(), session=0))
    assert up.error is None
    sessions = [p.session for p in ch.vehicle_saw]
    assert sessions[:2] == [0, 0]  # ResetSessions, CreateFile
    assert set(sessions[2:]) == {2}  # from the CreateFile ACK on
    assert (root / "APM" / "scripts" / "helixd-guard.lua").read_bytes() == five_kb()


def test_an_existing_file_is_replaced_without_making_directories(root: Path) -> None:
    (root / "APM" / "scripts").mkdir(parents=True)
    (root / "APM" / "scripts" / "helixd-guard.lua").write_bytes(b"x" * 9000)
    with FtpServer(root) as srv:
        ch = Channel(srv)
        up = ch.run(FtpUpload(GUARD, b"-- new guard\n", chunk_len=5))
    assert up.error is None
    assert (root / "APM" / "scripts" / "helixd-guard.lua").read_bytes() == b"-- new guard\n"
    assert FtpOp.CreateDirectory not in ch.ops()
    assert [p.size for p in ch.vehicle_saw if p.opcode == FtpOp.WriteFile] == [5, 5, 3]


def test_an_empty_file(root: Path) -> None:
    with FtpServer(root) as srv:
        ch = Channel(srv)
        up = ch.run(FtpUpload("/empty.lua", b""))
    assert up.error is None and up.remote_crc32 == 0
    assert (root / "empty.lua").read_bytes() == b""
    assert FtpOp.WriteFile not in ch.ops()


def test_existing_directories_are_fine(root: Path) -> None:
    (root / "APM").mkdir()
    with FtpServer(root) as srv:
        ch = Channel(srv)
        up = ch.run(FtpUpload(GUARD, b"x", verify_crc=False))
    assert up.error is None and up.remote_crc32 is None
    mkdirs = [p for p in ch.vehicle_saw if p.opcode == FtpOp.CreateDirectory]
    assert len(mkdirs) == 2  # /APM answered FileExists, which is fine
    assert ch.ops()[-1] == FtpOp.TerminateSession
    assert (root / "APM" / "scripts" / "helixd-guard.lua").read_bytes() == b"x"


def test_a_lost_reply_is_asked_again_with_the_same_request(root: Path) -> None:
    # fates in sending order: reset, its ack, create, its nak, mkdir, ack, mkdir, ack,
    # create, ack, the first write, and its ack: dropped
    fates = [DELIVER] * 11 + [DROP]
    with FtpServer(root) as srv:
        ch = Channel(srv, fates)
        up = ch.run(FtpUpload(GUARD, five_kb()))
    assert up.error is None and up.resends == 1
    writes = [p for p in ch.vehicle_saw if p.opcode == FtpOp.WriteFile]
    assert writes[0] == writes[1]  # sent again unchanged: ArduPilot answers from its last reply
    assert (root / "APM" / "scripts" / "helixd-guard.lua").read_bytes() == five_kb()


def test_a_stale_reply_is_ignored(root: Path) -> None:
    with FtpServer(root) as srv:

        def serve(requests: list[bytes]) -> list[bytes]:
            (request,) = requests
            return srv.handle(request, sysid=GCS[0], compid=GCS[1], now_s=0.0)

        up = FtpUpload("/d/x.lua", b"x")
        (reset_ack,) = serve(up.start(0.0))
        (not_found,) = serve(up.on_reply(reset_ack, 0.0))  # CreateFile: FileNotFound
        (mkdir_ack,) = serve(up.on_reply(not_found, 0.0))
        second_create = up.on_reply(mkdir_ack, 0.0)
        assert FtpPayload.unpack(second_create[0]).opcode == FtpOp.CreateFile
        # the first CreateFile's NAK again (late, or duplicated): same req_opcode, old seq
        assert up.on_reply(not_found, 0.1) == [] and not up.done
        assert up.on_reply(mkdir_ack, 0.1) == [] and not up.done
        (create_ack,) = serve(second_create)
        (write,) = up.on_reply(create_ack, 0.2)
        w = FtpPayload.unpack(write)
        assert w.opcode == FtpOp.WriteFile
        # an ACK with the right seq number but for another offset is not this write's
        forged = FtpPayload(w.seq_number + 1, w.session, FtpOp.Ack, 0, FtpOp.WriteFile, 0, 7)
        assert up.on_reply(forged.pack(), 0.3) == [] and up.bytes_acked == 0
        assert up.on_reply(serve([write])[0], 0.3) != [] and up.bytes_acked == 1


@pytest.mark.parametrize(("session", "slow"), [(1, False), (0, True)])
def test_a_lost_first_reply_on_a_one_session_autopilot(
    root: Path, session: int, slow: bool
) -> None:
    # reset, its ack, CreateFile (claims the only slot), its FileNotFound NAK: dropped
    fates = [DELIVER, DELIVER, DELIVER, DROP]
    with FtpServer(root, max_sessions=1) as srv:
        ch = Channel(srv, fates)
        up = ch.run(FtpUpload(GUARD, b"x", session=session))
    assert up.error is None
    # with its own session the repeat finds the slot and gets the kept NAK again at once;
    # with session 0 it claims anew and must wait out the 3 s the first claim holds the slot
    assert (ch.now_s > 3.0) is slow
    assert (up.resends > 5) is slow


def no_long_drop_runs(fates: list[int]) -> list[int]:
    """At most 3 drops in a row: every loss pattern the retry budget must absorb."""
    out: list[int] = []
    run = 0
    for f in fates:
        run = run + 1 if f == DROP else 0
        out.append(DELIVER if run > 3 else f)
        if run > 3:
            run = 0
    return out


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    data=hs.one_of(hs.just(five_kb()), hs.binary(max_size=1500)),
    fates=hs.lists(
        hs.sampled_from([DELIVER, DELIVER, DELIVER, DROP, DUPLICATE, DELAY]), max_size=120
    ).map(no_long_drop_runs),
    max_sessions=hs.sampled_from([1, 5]),
    chunk_len=hs.sampled_from([MAX_DATA_LEN, 100, 7]),
)
def test_upload_survives_lost_duplicated_and_late_payloads(
    data: bytes, fates: list[int], max_sessions: int, chunk_len: int
) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        with FtpServer(root, max_sessions=max_sessions) as srv:
            ch = Channel(srv, fates)
            up = ch.run(FtpUpload(GUARD, data, chunk_len=chunk_len))
            assert up.error is None, up.error
            assert srv.open_files == 0
        assert (root / "APM" / "scripts" / "helixd-guard.lua").read_bytes() == data
        assert up.remote_crc32 == crc32_ardupilot(data)


def test_no_sessions_available_is_waited_out(root: Path) -> None:
    with FtpServer(root, max_sessions=1) as srv:
        # another ground station holds the only session (opened at t = 0, then silent)
        busy = FtpPayload.request(FtpOp.CreateFile, 0, 0, data=b"/other.bin").pack()
        assert FtpPayload.unpack(srv.handle(busy, sysid=254, compid=1, now_s=0.0)[0]).opcode == (
            FtpOp.Ack
        )
        ch = Channel(srv)
        up = ch.run(FtpUpload("/mine.lua", b"mine"))
        assert up.error is None
        assert up.resends >= 5  # ~3 s of NoSessionsAvailable at 0.5 s per retry
        assert srv.open_files == 0
    assert (root / "mine.lua").read_bytes() == b"mine"


def test_silence_fails_after_the_retries(root: Path) -> None:
    up = FtpUpload(GUARD, b"x", reply_timeout_s=1.0, retries=3)
    sent = up.start(10.0)
    assert up.deadline_s == 11.0
    for t in (10.5, 11.0, 12.0, 13.0):
        more = up.on_time(t)
        assert more == ([] if t == 10.5 else sent)
    assert not up.done
    assert up.on_time(14.0) == []  # nothing to release: no session was asked for yet
    assert up.done and isinstance(up.error, FtpTransferError)
    assert str(up.error) == f"FTP upload of {GUARD}: no reply to ResetSessions after 3 retries"
    assert (up.error.path, up.error.op, up.error.nak) == (GUARD, FtpOp.ResetSessions, None)
    assert up.error.timed_out  # a link problem, not a refusal
    assert up.resends == 3 and up.deadline_s == float("inf")


def test_a_read_only_path_fails_naming_the_path_the_op_and_the_errno(root: Path) -> None:
    with FtpServer(root) as srv:
        ch = Channel(srv)
        up = ch.run(FtpUpload("@ROMFS/scripts/guard.lua", b"x"))
    err = up.error
    assert isinstance(err, FtpTransferError)
    assert str(err) == (
        "FTP upload of @ROMFS/scripts/guard.lua: CreateFile refused: FailErrno (errno 30 EROFS)"
    )
    assert err.op == FtpOp.CreateFile and err.nak is not None
    assert (err.nak.error, err.nak.errno) == (FtpErr.FailErrno, errno.EROFS)
    assert not err.timed_out
    assert ch.ops()[-1] == FtpOp.TerminateSession  # the session is released, unanswered


def test_a_write_refused_midway_fails_and_closes_the_file(root: Path) -> None:
    with FtpServer(root, max_file_bytes=1000) as srv:
        ch = Channel(srv)
        up = ch.run(FtpUpload("/big.bin", five_kb()))
        assert srv.open_files == 0  # the final TerminateSession closed it
    assert isinstance(up.error, FtpTransferError)
    assert str(up.error) == (
        "FTP upload of /big.bin: WriteFile at offset 956 refused: FailErrno (errno 28 ENOSPC)"
    )
    assert up.error.op == FtpOp.WriteFile and up.bytes_acked == 956
    assert ch.ops()[-1] == FtpOp.TerminateSession


def test_a_parent_that_is_a_file_fails(root: Path) -> None:
    (root / "APM").write_bytes(b"not a dir")
    with FtpServer(root) as srv:
        up = Channel(srv).run(FtpUpload(GUARD, b"x"))
    assert isinstance(up.error, FtpTransferError)
    assert "CreateFile refused: FailErrno (errno 20 ENOTDIR)" in str(up.error)


def test_missing_directories_without_create_dirs(root: Path) -> None:
    with FtpServer(root) as srv:
        ch = Channel(srv)
        up = ch.run(FtpUpload(GUARD, b"x", create_dirs=False))
    assert isinstance(up.error, FtpTransferError)
    assert str(up.error) == f"FTP upload of {GUARD}: CreateFile refused: FileNotFound"
    assert FtpOp.CreateDirectory not in ch.ops()


def test_a_crc_mismatch_fails_after_releasing_the_session(root: Path) -> None:
    def corrupt(r: FtpPayload) -> FtpPayload:
        if r.req_opcode == FtpOp.CalcFileCRC32 and r.opcode == FtpOp.Ack:
            bad = struct.pack("<I", struct.unpack("<I", r.data)[0] ^ 1)
            return FtpPayload(r.seq_number, r.session, r.opcode, 4, r.req_opcode, 0, 0, bad)
        return r

    data = five_kb()
    with FtpServer(root) as srv:
        ch = Channel(srv, tamper=corrupt)
        up = ch.run(FtpUpload(GUARD, data))
        assert srv.open_files == 0
    assert isinstance(up.error, FtpTransferError)
    good = FIVE_KB_CRC32
    assert str(up.error) == (
        f"FTP upload of {GUARD}: CRC32 mismatch after writing 5120 bytes: "
        f"autopilot 0x{good ^ 1:08x}, sent 0x{good:08x}"
    )
    assert ch.ops()[-2:] == [FtpOp.CalcFileCRC32, FtpOp.TerminateSession]


@pytest.mark.parametrize(
    ("path", "kwargs", "match"),
    [
        ("", {}, "non-empty"),
        ("/APM/scripts/", {}, "directory"),
        ("/APM/ščripts/x.lua", {}, "ASCII"),
        ("/" + "a" * 238, {}, "at most 238"),
        (GUARD, {"chunk_len": 0}, "chunk_len"),
        (GUARD, {"chunk_len": 240}, "chunk_len"),
        (GUARD, {"reply_timeout_s": 0.0}, "reply_timeout_s"),
        (GUARD, {"reply_timeout_s": float("nan")}, "reply_timeout_s"),
        (GUARD, {"retries": -1}, "retries"),
        (GUARD, {"session": 256}, "session"),
    ],
)
def test_arguments_are_checked(path: str, kwargs: dict[str, float], match: str) -> None:
    with pytest.raises(ValueError, match=match):
        FtpUpload(path, b"x", **kwargs)  # type: ignore[arg-type]


junk = hs.one_of(
    hs.binary(max_size=260),
    hs.builds(
        lambda seq, op, req, size, data: FtpPayload(
            seq, 0, op, max(size, len(data)), req, 0, 0, data
        ).pack(),
        hs.integers(0, 40),
        hs.sampled_from([FtpOp.Ack, FtpOp.Nack, FtpOp.WriteFile]),
        hs.sampled_from([int(o) for o in FtpOp]),
        hs.integers(0, MAX_DATA_LEN),
        hs.binary(max_size=4),
    ),
)


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(hs.lists(junk, max_size=40))
def test_hostile_replies_end_in_success_or_a_clear_error(noise: list[bytes]) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        with FtpServer(root) as srv:
            ch = Channel(srv)
            up = FtpUpload("/x.lua", b"0123456789" * 60)
            ch._to_vehicle(up.start(0.0))
            pending = deque(noise)
            while not up.done and ch.now_s < 300.0:
                ch._deliver_requests()
                if pending:
                    ch.to_gcs.appendleft(pending.popleft())  # junk first
                while ch.to_gcs:
                    ch._to_vehicle(up.on_reply(ch.to_gcs.popleft(), ch.now_s))
                ch.now_s += 0.05
                ch._to_vehicle(up.on_time(ch.now_s))
        assert up.done
        if up.error is None:
            assert (root / "x.lua").read_bytes() == b"0123456789" * 60
        else:
            assert isinstance(up.error, FtpTransferError)
            assert str(up.error).startswith("FTP upload of /x.lua: ")


class MemoryLink:
    """An FtpLink to the server in memory, on a simulated clock that moves on a timeout."""

    def __init__(self, srv: FtpServer) -> None:
        self.srv = srv
        self.now_s = 0.0
        self.inbox: deque[bytes] = deque()
        self.sent: list[bytes] = []

    def clock(self) -> float:
        return self.now_s

    def send(self, payload: bytes) -> None:
        self.sent.append(payload)
        self.inbox.extend(self.srv.handle(payload, sysid=GCS[0], compid=GCS[1], now_s=self.now_s))

    async def recv(self, timeout_s: float) -> bytes | None:
        await asyncio.sleep(0)
        if self.inbox:
            return self.inbox.popleft()
        self.now_s += timeout_s
        return None


async def test_run_upload_over_a_link(root: Path) -> None:
    with FtpServer(root) as srv:
        link = MemoryLink(srv)
        up = await run_ftp(FtpUpload(GUARD, five_kb()), link, link.clock)
        assert up.done and up.error is None
    assert (root / "APM" / "scripts" / "helixd-guard.lua").read_bytes() == five_kb()


async def test_run_upload_raises_the_error_and_releases(root: Path) -> None:
    with FtpServer(root) as srv:
        link = MemoryLink(srv)
        with pytest.raises(FtpTransferError, match="EROFS"):
            await run_ftp(FtpUpload("@ROMFS/x.lua", b"x"), link, link.clock)
        assert FtpPayload.unpack(link.sent[-1]).opcode == FtpOp.TerminateSession


# --- DirectoryProbe ------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("files", "exists"),
    [
        ((), True),  # an empty directory: EndOfFile NAK
        (("a.lua",), True),  # entries: ACK
        (None, False),  # FileNotFound
    ],
    ids=["empty_dir", "dir_with_a_file", "missing"],
)
def test_directory_probe(root: Path, files: tuple[str, ...] | None, exists: bool) -> None:
    if files is not None:
        (root / "APM" / "scripts").mkdir(parents=True)
        for name in files:
            (root / "APM" / "scripts" / name).write_bytes(b"x")
    with FtpServer(root) as srv:
        ch = Channel(srv)
        probe = ch.run(DirectoryProbe("/APM/scripts"))
        assert probe.done and probe.error is None
        assert probe.exists is exists
        assert ch.ops() == [FtpOp.ListDirectory, FtpOp.TerminateSession]
        assert srv.open_files == 0


def test_directory_probe_survives_lost_and_duplicated_messages(root: Path) -> None:
    (root / "scripts").mkdir()
    with FtpServer(root) as srv:
        ch = Channel(srv, fates=[DROP, DUPLICATE, DELIVER, DROP, DELAY])
        probe = ch.run(DirectoryProbe("scripts"))
        assert probe.error is None and probe.exists is True
        assert probe.resends >= 1  # the dropped ListDirectory was sent again


def test_directory_probe_of_a_file_is_an_error_naming_it(root: Path) -> None:
    (root / "scripts").write_bytes(b"not a directory")
    with FtpServer(root) as srv:
        probe = Channel(srv).run(DirectoryProbe("scripts"))
    assert probe.done and probe.exists is None
    assert isinstance(probe.error, FtpTransferError)
    assert str(probe.error).startswith("FTP listing of scripts: ListDirectory refused")


async def test_run_ftp_probes_over_a_link(root: Path) -> None:
    with FtpServer(root) as srv:
        link = MemoryLink(srv)
        probe = await run_ftp(DirectoryProbe("/APM"), link, link.clock)
    assert probe.exists is False
