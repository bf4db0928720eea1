"""The Helix plant served on UDP as SITL's JSON physics (helixd.plant.json_server): lockstep
answers to each frame's sender, bad datagrams counted and unanswered, a restarted SITL, the
truth file, the socket closed when stopped."""

from __future__ import annotations

import json
import socket
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import pytest

from helixd.plant.json_physics import ServoFrame, encode_servo_frame
from helixd.plant.json_server import TRUTH_COLUMNS, PlantStats, open_socket, serve_plant
from helixd.plant.plant_config import PlantConfig

RATE_HZ = 400
ROLL_US = (1800, 1800, 1200, 1200)


def datagram(count: int, scrolls_us: tuple[int, int, int, int] = ROLL_US) -> bytes:
    return encode_servo_frame(ServoFrame(RATE_HZ, count, (*scrolls_us, *([0] * 12))))


@dataclass
class Served:
    port: int
    stop: threading.Event
    results: list[PlantStats] = field(default_factory=list)

    @property
    def stats(self) -> PlantStats:
        assert len(self.results) == 1, "the server did not return"
        return self.results[0]


@contextmanager
def served(truth_csv: Path | None = None) -> Iterator[Served]:
    """serve_plant on a free port in a thread; stopped, and joined, on leaving."""
    sock = open_socket("127.0.0.1", 0)
    run = Served(sock.getsockname()[1], threading.Event())
    thread = threading.Thread(
        target=lambda: run.results.append(serve_plant(PlantConfig(), sock, run.stop, truth_csv)),
        daemon=True,
    )
    thread.start()
    try:
        yield run
    finally:
        run.stop.set()
        thread.join(timeout=10.0)
    assert not thread.is_alive()


@contextmanager
def sitl() -> Iterator[socket.socket]:
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.settimeout(5.0)
    try:
        yield sock
    finally:
        sock.close()


def exchange(sitl_sock: socket.socket, port: int, data: bytes) -> dict[str, object]:
    sitl_sock.sendto(data, ("127.0.0.1", port))
    body: dict[str, object] = json.loads(sitl_sock.recv(4096))
    return body


def test_served_on_udp_answering_each_frame_and_writing_the_truth(tmp_path: Path) -> None:
    truth = tmp_path / "truth.csv"
    with served(truth) as run, sitl() as s:
        s.sendto(b"not a servo packet", ("127.0.0.1", run.port))
        for k in range(RATE_HZ):  # one simulated second, lockstep
            body = exchange(s, run.port, datagram(k))
        assert body["timestamp"] == pytest.approx(1.0)
        assert body["position"][0] > 0.05  # type: ignore[index]
    assert run.stats.frames == RATE_HZ
    assert run.stats.bad_datagrams == 1
    assert run.stats.sim_time_s == pytest.approx(1.0)
    rows = truth.read_text(encoding="utf-8").splitlines()
    assert rows[0] == ",".join(TRUTH_COLUMNS)
    assert 10 <= len(rows) - 1 <= 11  # ten rows per simulated second
    assert float(rows[-1].split(",")[1]) > 0.05


def test_a_bad_datagram_gets_no_answer_and_the_next_frame_its_own() -> None:
    with served() as run, sitl() as s:
        for junk in (b"", b"\x00" * 40, datagram(0)[:-1]):  # empty, wrong magic, short
            s.sendto(junk, ("127.0.0.1", run.port))
        body = exchange(s, run.port, datagram(0))
        # the first answer is the frame's: nothing came back for the junk before it
        assert body["timestamp"] == pytest.approx(1.0 / RATE_HZ)
    assert run.stats.bad_datagrams == 3
    assert run.stats.frames == 1


def test_each_answer_goes_to_the_address_its_frame_came_from() -> None:
    with served() as run, sitl() as first, sitl() as second:
        a = exchange(first, run.port, datagram(0))
        b = exchange(second, run.port, datagram(1))
        c = exchange(first, run.port, datagram(2))
    assert [x["timestamp"] for x in (a, b, c)] == pytest.approx([k / RATE_HZ for k in (1, 2, 3)])


def test_a_restarted_sitl_starts_the_plant_and_the_truth_over(tmp_path: Path) -> None:
    truth = tmp_path / "truth.csv"
    with served(truth) as run, sitl() as s:
        for k in range(RATE_HZ // 2):
            before = exchange(s, run.port, datagram(100 + k))
        after = exchange(s, run.port, datagram(0, (1500,) * 4))  # the frame count went back
    assert before["position"][0] > 0.01  # type: ignore[index]
    assert after["timestamp"] == pytest.approx(1.0 / RATE_HZ)
    assert after["position"] == [0.0, 0.0, 0.0]  # at rest where it started
    assert run.stats.restarts == 1
    assert run.stats.frames == 1  # counted since the restart
    times = [float(row.split(",")[0]) for row in truth.read_text("utf-8").splitlines()[1:]]
    assert times[0] == pytest.approx(1.0 / RATE_HZ)
    assert times[-1] == pytest.approx(1.0 / RATE_HZ)  # a row again at once after the restart
    assert sorted(times[:-1]) == times[:-1] and len(times) >= 6


def test_stopped_before_any_frame_it_closes_the_socket_and_reports_nothing() -> None:
    sock = open_socket("127.0.0.1", 0)
    stop = threading.Event()
    stop.set()
    stats = serve_plant(PlantConfig(), sock, stop)
    assert (stats.frames, stats.bad_datagrams, stats.restarts, stats.sim_time_s) == (0, 0, 0, 0.0)
    assert stats.rate_hz == 0.0
    assert sock.fileno() == -1  # closed


def test_rate_is_frames_per_wall_second() -> None:
    assert PlantStats(800, 0, 0, 2.0, 4.0).rate_hz == pytest.approx(200.0)
    assert PlantStats(800, 0, 0, 2.0, 0.0).rate_hz == 0.0


def test_open_socket_binds_the_port_and_wakes_to_look_at_stop() -> None:
    sock = open_socket("127.0.0.1", 0)
    try:
        assert sock.getsockname()[1] > 0
        assert sock.type == socket.SOCK_DGRAM
        assert sock.gettimeout() is not None and sock.gettimeout() > 0
    finally:
        sock.close()
