"""helixd.report.gcs_report: STATUSTEXT / NAMED_VALUE_FLOAT as a ground station receives them."""

from __future__ import annotations

import math
import os
from typing import Any

from hypothesis import given, settings
from hypothesis import strategies as hs

os.environ.setdefault("MAVLINK20", "1")
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.config.recorder import GcsReportConfig
from helixd.config.root import HelixdConfig
from helixd.link.statustext import StatusTextAssembler
from helixd.report.gcs_report import (
    GcsReporter,
    PhaseChange,
    Progress,
    ReportedFault,
    Said,
    WaypointReached,
    chunk_statustext,
    fault_text,
)
from helixd.safety.watchdogs import FaultCause

CFG = GcsReportConfig()


def wire(msgs: list[Any]) -> list[Any]:
    """Pack and decode as a second MAVLink client would."""
    tx = mavlink.MAVLink(None, srcSystem=247, srcComponent=191)
    rx = mavlink.MAVLink(None)
    out = []
    for m in msgs:
        decoded = rx.decode(bytearray(m.pack(tx)))
        out.append(decoded)
    return out


def joined(lines: list[str]) -> str:
    """The text of lines that each start with ``helixd: `` (every line of a long text does:
    a ground station shows each as a line of its own), the prefix said once."""
    assert lines and all(line.startswith("helixd: ") for line in lines), lines
    return "helixd: " + " ".join(line.removeprefix("helixd: ") for line in lines)


def texts(msgs: list[Any]) -> list[tuple[int, str]]:
    asm = StatusTextAssembler(timeout_s=5.0)
    got: list[tuple[int, str]] = []
    for m in wire(msgs):
        if m.get_type() != "STATUSTEXT":
            continue
        text = m.text if isinstance(m.text, str) else m.text.decode("ascii")
        for t in asm.add(247, 191, int(m.severity), text, int(m.id), int(m.chunk_seq), 0.0):
            assert t.complete
            got.append((t.severity, t.text))
    assert asm.pending == 0
    return got


def test_severities() -> None:
    r = GcsReporter(CFG, 0.0)
    out = r.feed(PhaseChange("run"), 0.0)
    out += r.feed(WaypointReached(2, 10), 0.0)
    out += r.feed(ReportedFault("pose_stale", "no pose for 0.6 s"), 0.0)
    out += r.feed(ReportedFault("slip_high", stopped=False), 0.0)
    assert texts(out) == [
        (5, "helixd: run"),
        (6, "helixd: reached WP 3/10"),
        (2, "helixd: FAULT: position lost: no pose for 0.6 s"),
        (4, "helixd: FAULT: slip high"),
    ]
    assert all(int(m.id) == 0 for m in out)  # short texts: id 0


def test_a_fault_reads_in_words_never_its_cause_identifier() -> None:
    """A tablet shows "stopped: pilot took over", not ``pilot_takeover`` or ``pose_stale``."""
    r = GcsReporter(CFG, 0.0)
    out = r.feed(ReportedFault("pilot_takeover", "mode changed to HOLD (helixd set MANUAL)"), 0.0)
    out += r.feed(ReportedFault("pose_stale", "pose is 0.61 s old (limit 0.5 s)"), 0.0)
    assert [t for _, t in texts(out)] == [
        "helixd: stopped: pilot took over: mode changed to",
        "helixd: HOLD (helixd set MANUAL)",
        "helixd: FAULT: position lost: pose is 0.61 s old",
        "helixd: (limit 0.5 s)",
    ]
    for cause in [*FaultCause, "fallback"]:
        assert "_" not in fault_text(cause), cause  # every identifier has its words


def test_long_text_goes_out_as_whole_lines_split_between_words() -> None:
    # a GCS showing each chunk as a line used to read "…DO_PAUSE_CO" / "NTINUE 0 …"
    r = GcsReporter(CFG, 0.0)
    detail = "DO_PAUSE_CONTINUE 0 (system 255) then a few more words to wrap"
    out = r.feed(ReportedFault("f", detail), 0.0)
    lines = [t for _, t in texts(out)]
    assert all(int(m.id) == 0 for m in out)  # each line stands alone
    assert all(0 < len(t) <= 50 for t in lines)
    assert joined(lines) == "helixd: FAULT: f: " + detail  # nothing lost, no word cut


def test_text_of_150_chars_keeps_its_tail_and_sends_no_empty_line() -> None:
    r = GcsReporter(CFG, 0.0)
    words = " ".join(["abcd"] * 28)  # 8 + 139 = 147 characters
    lines = [t for _, t in texts(r.feed(PhaseChange(words), 0.0))]
    assert joined(lines) == "helixd: " + words
    assert all(len(t) <= 50 for t in lines) and len(lines) == 4  # 42 characters after the prefix


def test_multiple_of_fifty_ends_with_empty_chunk() -> None:
    msgs = chunk_statustext(4, "a" * 100, 7)
    assert [len(m.text) for m in msgs] == [50, 50, 0]
    assert texts(msgs) == [(4, "a" * 100)]


def test_non_ascii_and_overlong_marked() -> None:
    cfg = GcsReportConfig(max_text_chars=60)
    r = GcsReporter(cfg, 0.0)
    out = r.feed(PhaseChange("pond ✓ " + "y" * 200), 0.0)
    lines = [t for _, t in texts(out)]
    # the overlong word is cut to the lines the 60 characters allow, the cut marked
    assert lines == ["helixd: pond ?", "helixd: " + "y" * 39 + "..."]


def test_helixds_own_non_ascii_is_spelt_in_ascii() -> None:
    r = GcsReporter(GcsReportConfig(), 0.0)
    ((_, text),) = texts(r.feed(PhaseChange("ok — 2/2, leg 1 → 2, 90°"), 0.0))
    assert text == "helixd: ok - 2/2, leg 1 -> 2, 90 deg"


@settings(max_examples=200, deadline=None)
@given(
    text=hs.text(alphabet=hs.characters(exclude_characters="—–→°×µ"), max_size=400),
    text_id=hs.integers(1, 65535),
    sev=hs.integers(0, 7),
)
def test_chunks_always_reassemble(text: str, text_id: int, sev: int) -> None:
    msgs = chunk_statustext(sev, text, text_id)
    clean = "".join(c if " " <= c <= "~" else "?" for c in text)
    assert texts(msgs) == [(sev, clean)]


def test_the_same_text_within_the_window_shows_once() -> None:
    r = GcsReporter(GcsReportConfig(repeat_window_s=3.0, burst=10), 0.0)
    said = Said("start refused: new plan failed its checks", 3)
    assert len(texts(r.feed(said, 0.0))) == 1
    assert r.feed(said, 1.0) == [] and r.queued == 0  # the pane has it
    assert len(texts(r.feed(Said("another", 3), 1.5))) == 1
    assert len(texts(r.feed(said, 3.5))) == 1  # later: news again
    every = GcsReporter(GcsReportConfig(repeat_window_s=0.0, burst=10), 0.0)
    assert len(every.feed(said, 0.0)) == len(every.feed(said, 0.1)) == 1


def test_a_long_text_is_cut_between_words() -> None:
    r = GcsReporter(GcsReportConfig(max_text_chars=60), 0.0)
    words = " ".join(["waypoint"] * 30)
    lines = [t for _, t in texts(r.feed(PhaseChange(words), 0.0))]
    assert lines[-1].endswith("waypoint...") and all(len(t) <= 50 for t in lines)


def test_rate_limit_with_burst_and_faults_first() -> None:
    cfg = GcsReportConfig(rate_hz=2.0, burst=3, queue_max=50)
    r = GcsReporter(cfg, 0.0)
    out: list[Any] = []
    for i in range(10):
        out += r.feed(WaypointReached(i, 10), 0.0)
    assert len(out) == 3 and r.queued == 7
    assert r.tick(0.2) == []  # 0.4 token
    out = r.feed(ReportedFault("stall"), 0.3)  # jumps the queue, still waits for a token
    assert out == [] and r.queued == 8
    out = r.tick(0.5)
    assert texts(out) == [(2, "helixd: FAULT: stuck, not moving")]
    out = r.tick(1.0)
    assert texts(out) == [(6, "helixd: reached WP 4/10")]
    sent = 0
    for k in range(1, 100):
        sent += len(r.tick(1.0 + k * 0.1))
    assert sent == 6 and r.queued == 0


def test_queue_overflow_drops_non_faults_and_says_so() -> None:
    cfg = GcsReportConfig(rate_hz=1.0, burst=1, queue_max=3)
    r = GcsReporter(cfg, 0.0)
    r.feed(PhaseChange("a"), 0.0)  # goes out (the burst)
    for i in range(3):
        r.feed(WaypointReached(i, 9), 0.0)
    r.feed(ReportedFault("one"), 0.0)
    r.feed(ReportedFault("two"), 0.0)
    assert r.queued == 3 and r.dropped == 2
    got: list[tuple[int, str]] = []
    for k in range(1, 6):
        got += texts(r.tick(float(k)))
    assert got == [
        (2, "helixd: FAULT: one"),
        (2, "helixd: FAULT: two"),
        (6, "helixd: reached WP 3/9"),
        (5, "helixd: 2 messages dropped (rate limit)"),
    ]


def test_named_values_at_rate_and_never_nan() -> None:
    r = GcsReporter(GcsReportConfig(named_value_rate_hz=2.0), 10.0)
    assert r.tick(10.0) == []  # nothing known yet
    r.feed(Progress(0.25, 3), 10.1)
    msgs: list[Any] = []
    t = 10.1
    while t < 12.1:
        msgs += r.tick(t)
        t += 0.05
    got = wire(msgs)
    xt = [m for m in got if m.name == "xtrack_m"]
    wp = [m for m in got if m.name == "wp_index"]
    assert 3 <= len(xt) <= 5 and len(xt) == len(wp)
    assert all(abs(m.value - 0.25) < 1e-6 for m in xt) and all(m.value == 3.0 for m in wp)
    assert int(xt[0].time_boot_ms) >= 400
    r.feed(Progress(float("nan"), None), 12.2)
    assert r.tick(13.0) == []


def test_disabled_sends_nothing() -> None:
    r = GcsReporter(GcsReportConfig(enabled=False), 0.0)
    r.feed(Progress(1.0, 1), 0.0)
    assert r.feed(ReportedFault("x"), 0.0) == [] and r.tick(5.0) == []


def test_config_section_in_top_level() -> None:
    assert HelixdConfig().gcs_report == GcsReportConfig()


_times = hs.one_of(
    hs.floats(min_value=-1e3, max_value=1e6), hs.sampled_from([math.nan, math.inf, -math.inf])
)
_events = hs.one_of(
    hs.builds(PhaseChange, hs.text(max_size=80)),
    hs.builds(WaypointReached, hs.integers(-5, 10**6), hs.integers(-5, 10**6)),
    hs.builds(ReportedFault, hs.text(max_size=300), hs.text(max_size=300), hs.booleans()),
    hs.builds(
        Progress,
        hs.one_of(hs.none(), hs.floats(allow_nan=True, allow_infinity=True)),
        hs.one_of(hs.none(), hs.integers(-(10**30), 10**30)),
    ),
)


@settings(max_examples=150, deadline=None)
@given(steps=hs.lists(hs.tuples(hs.booleans(), _events, _times), max_size=40))
def test_total_any_events_any_times(steps: list[tuple[bool, Any, float]]) -> None:
    """Garbage times and values: never an exception, never a bad or non-finite message."""
    cfg = GcsReportConfig(queue_max=5, burst=2)
    r = GcsReporter(cfg, 0.0)
    out: list[Any] = []
    for is_tick, event, t in steps:
        out += r.tick(t) if is_tick else r.feed(event, t)
        assert r.queued <= cfg.queue_max
    for m in wire(out):
        if m.get_type() == "NAMED_VALUE_FLOAT":
            assert m.value == m.value and abs(m.value) != float("inf")
        else:
            assert len(m.text) <= 50 and all(" " <= c <= "~" for c in m.text)


def test_seen_by_a_second_ground_station_through_the_simulated_autopilot() -> None:
    """Real UDP: helixd on link 0, a GCS on link 1; the autopilot forwards our messages
    (MAVLink_routing) and the GCS reassembles the texts and sees the named values."""
    import time

    from tests.support.harness import GCS_SYSID, client, running_sim_links

    with running_sim_links(["udpin:127.0.0.1:0", "udpin:127.0.0.1:0"]) as srv:
        url0, url1 = (f"udpout:127.0.0.1:{p}" for p in srv.local_ports)
        with client(url0, sysid=GCS_SYSID) as ours, client(url1, sysid=255) as gcs:
            r = GcsReporter(GcsReportConfig(named_value_rate_hz=10.0), time.monotonic())
            asm = StatusTextAssembler(timeout_s=5.0)
            got: list[tuple[int, str]] = []
            names: set[str] = set()
            long_fault = ReportedFault(
                "pose_stale", "no LOCAL_POSITION_NED for 0.62 s; HOLD requested"
            )
            deadline = time.monotonic() + 10.0
            while time.monotonic() < deadline and (len(got) < 2 or len(names) < 2):
                ours.heartbeat()
                gcs.heartbeat()  # both links active: routes learned
                now = time.monotonic()
                out = r.feed(PhaseChange("run"), now) + r.feed(long_fault, now)
                r.feed(Progress(0.42, 2), now)
                for m in out + r.tick(now) + r.tick(now + 0.2):
                    ours.mav.send(m)
                end = time.monotonic() + 0.3
                while time.monotonic() < end:
                    m = gcs.conn.recv_match(blocking=True, timeout=0.05)
                    if m is None or int(m.get_srcSystem()) != GCS_SYSID:
                        continue
                    if m.get_type() == "STATUSTEXT":
                        sev, text, tid, seq = (
                            int(m.severity),
                            str(m.text),
                            int(m.id),
                            int(m.chunk_seq),
                        )
                        for t in asm.add(GCS_SYSID, 190, sev, text, tid, seq, time.monotonic()):
                            assert t.complete
                            got.append((t.severity, t.text))
                    elif m.get_type() == "NAMED_VALUE_FLOAT":
                        names.add(str(m.name))
            assert (5, "helixd: run") in got
            faults = [t for sev, t in got if sev == 2]  # whole lines, split between words
            assert joined(faults) == "helixd: FAULT: position lost: " + long_fault.detail
            assert names == {"xtrack_m", "wp_index"}
