"""The simulator's long STATUSTEXTs reassemble into the original text on helixd's side."""

from __future__ import annotations

from helixd.link.statustext import StatusTextAssembler
from helixd.sim.firmware.messages import statustexts


def test_long_text_chunks_reassemble() -> None:
    text = "PreArm: " + "Check the scroll motors, the mode switch and the EKF origin " * 2
    assert len(text) % 50 != 0  # (see the report: multiples of 50 lack ArduPilot's empty tail)
    chunks = statustexts(2, text, 17)
    assert len(chunks) == 3
    assert [int(m.chunk_seq) for m in chunks] == [0, 1, 2]
    assert {int(m.id) for m in chunks} == {17}
    asm = StatusTextAssembler(2.0)
    out = []
    for m in chunks:
        raw = m.text if isinstance(m.text, str) else bytes(m.text).decode()
        out += asm.add(1, 1, int(m.severity), raw, int(m.id), int(m.chunk_seq), 0.0)
    assert [(t.text, t.complete) for t in out] == [(text, True)]
    (short,) = statustexts(4, "GCS Failsafe", 18)
    assert int(short.id) == 0


def test_text_of_a_multiple_of_50_ends_with_an_empty_chunk() -> None:
    text = "A" * 50 + "B" * 50
    chunks = statustexts(6, text, 3)
    texts = [m.text if isinstance(m.text, str) else bytes(m.text).decode() for m in chunks]
    assert [t.rstrip("\x00") for t in texts] == ["A" * 50, "B" * 50, ""]
    asm = StatusTextAssembler(2.0)
    out = []
    for m, raw in zip(chunks, texts, strict=True):
        out += asm.add(1, 1, int(m.severity), raw, int(m.id), int(m.chunk_seq), 0.0)
    assert [(t.text, t.complete) for t in out] == [(text, True)]
