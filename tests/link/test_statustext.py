"""Chunked STATUSTEXT reassembly: pure rules, then over a real socket."""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st
from structlog.testing import capture_logs

from helixd.link.statustext import CHUNK_CHARS, MISSING_MARK, StatusTextAssembler
from tests.support.peer import linked, until


def ardupilot_chunks(text: str, text_id: int) -> list[tuple[int, int, str]]:
    """(id, chunk_seq, text) as GCS::send_statustext sends them (trailing empty chunk when
    the length is a multiple of 50)."""
    if len(text) <= CHUNK_CHARS:
        return [(0, 0, text)]
    out: list[tuple[int, int, str]] = []
    rest = text
    for seq in range(256):
        remainder_len = len(rest)
        out.append((text_id, seq, rest[:CHUNK_CHARS]))
        rest = rest[CHUNK_CHARS:]
        if remainder_len < CHUNK_CHARS:
            break
    return out


def feed(asm: StatusTextAssembler, chunks: list[tuple[int, int, str]], t: float = 0.0) -> list:
    out = []
    for text_id, seq, text in chunks:
        out += asm.add(1, 1, 4, text, text_id, seq, t)
    return out


def test_short_text_passes_at_once() -> None:
    got = feed(StatusTextAssembler(2.0), [(0, 0, "PreArm: Radio failsafe on")])
    assert [(t.text, t.complete) for t in got] == [("PreArm: Radio failsafe on", True)]


def test_long_text_comes_out_once_and_whole() -> None:
    text = "PreArm: " + "x" * 60 + " and the end"
    got = feed(StatusTextAssembler(2.0), ardupilot_chunks(text, 7))
    assert [(t.text, t.complete, t.chunks) for t in got] == [(text, True, 2)]


def test_exact_multiple_of_50_ends_with_an_empty_chunk() -> None:
    text = "y" * 100
    chunks = ardupilot_chunks(text, 3)
    assert [c[2] for c in chunks] == ["y" * 50, "y" * 50, ""]
    asm = StatusTextAssembler(2.0)
    assert feed(asm, chunks[:2]) == []
    assert [t.text for t in feed(asm, chunks[2:])] == [text]


def test_missing_last_chunk_times_out_marked() -> None:
    asm = StatusTextAssembler(2.0)
    chunks = ardupilot_chunks("z" * 120, 9)
    assert feed(asm, chunks[:2], t=0.0) == []
    assert asm.expire(1.9) == []
    (late,) = asm.expire(2.0)
    assert not late.complete and late.text == "z" * 100 + MISSING_MARK


def test_gap_before_the_end_is_marked() -> None:
    chunks = ardupilot_chunks("a" * 50 + "b" * 50 + "c" * 10, 4)
    asm = StatusTextAssembler(2.0)
    assert feed(asm, [chunks[2], chunks[0]]) == []  # chunk 1 may still come (out of order)
    (got,) = asm.expire(2.5)
    assert not got.complete and got.chunks == 2
    assert got.text == "a" * 50 + MISSING_MARK + "c" * 10


def test_interleaved_texts_and_bounded_pending() -> None:
    asm = StatusTextAssembler(2.0, max_pending=2)
    a, b = ardupilot_chunks("A" * 70, 1), ardupilot_chunks("B" * 70, 2)
    out = feed(asm, [a[0], b[0], b[1], a[1]])
    assert [t.text for t in out] == ["B" * 70, "A" * 70]
    for text_id in (10, 11, 12):  # a flood of starts never holds more than max_pending
        feed(asm, [(text_id, 0, "q" * 50)])
        assert asm.pending <= 2


@settings(max_examples=200, deadline=None)
@given(st.text(alphabet=st.characters(min_codepoint=32, max_codepoint=126), max_size=400))
def test_any_text_round_trips(text: str) -> None:
    got = feed(StatusTextAssembler(2.0), ardupilot_chunks(text, 5))
    assert [(t.text, t.complete) for t in got] == [(text, True)]


async def test_one_event_per_text_over_the_wire() -> None:
    text = "PreArm: Motors: Check SERVO1_FUNCTION, SERVO3_FUNCTION and RC3 trim please"
    async with linked() as (ap, peer):
        with capture_logs() as logs:
            for text_id, seq, chunk in ardupilot_chunks(text, 42):
                peer.send_as(
                    1,
                    1,
                    lambda c, i=text_id, s=seq, x=chunk: c.statustext_encode(2, x.encode(), i, s),
                )
            await until(lambda: ap.state.latest_statustext("PreArm") is not None, 3.0, "the text")
        assert ap.state.latest_statustext("PreArm") == text
        events = [e for e in logs if e["event"] == "autopilot_statustext"]
        assert [e["text"] for e in events] == [text]
