"""Reassemble ArduPilot's chunked STATUSTEXTs (pure: times are passed in).

ArduPilot (GCS::send_statustext, GCS_Common.cpp) sends a text of at most 50 characters as one
STATUSTEXT with ``id`` 0. A longer text gets a fresh non-zero ``id`` (a uint16 counter that
skips 0) and goes out as 50-character chunks with ``chunk_seq`` 0, 1, …; a chunk shorter than
50 characters ends it — when the length is a multiple of 50 the last chunk is empty. A chunk
can be lost on the way, so a text whose end never comes is emitted after ``timeout_s`` with
the missing pieces marked, and so is one whose end arrived with a gap before it.

Texts are keyed by sender (system, component) and ``id``; at most ``max_pending`` are held
(the oldest is emitted early if more arrive), so a flood of bogus ids cannot grow memory.
"""

from __future__ import annotations

from dataclasses import dataclass, field

__all__ = ["CHUNK_CHARS", "MISSING_MARK", "AssembledText", "StatusTextAssembler"]

CHUNK_CHARS = 50  # MAVLINK_MSG_STATUSTEXT_FIELD_TEXT_LEN
MAX_CHUNKS = 256  # chunk_seq is a uint8
MISSING_MARK = "…"


@dataclass(frozen=True, slots=True)
class AssembledText:
    severity: int
    text: str
    complete: bool  # False: a chunk is missing (timed out, evicted or a gap)
    chunks: int  # how many chunks arrived


@dataclass(slots=True)
class _PendingText:
    severity: int
    first_rx_s: float
    chunks: dict[int, str] = field(default_factory=dict)
    last_seq: int | None = None  # seq of the short (final) chunk, once seen


Key = tuple[int, int, int]  # (sysid, compid, id)


class StatusTextAssembler:
    def __init__(self, timeout_s: float, max_pending: int = 16) -> None:
        if not timeout_s > 0.0 or max_pending < 1:
            raise ValueError("timeout_s must be > 0 and max_pending >= 1")
        self.timeout_s = timeout_s
        self.max_pending = max_pending
        self._pending: dict[Key, _PendingText] = {}

    @property
    def pending(self) -> int:
        return len(self._pending)

    def add(
        self,
        sysid: int,
        compid: int,
        severity: int,
        text: str,
        text_id: int,
        chunk_seq: int,
        now_s: float,
    ) -> list[AssembledText]:
        """One received STATUSTEXT; returns the texts completed (or given up) by it."""
        out = self.expire(now_s)
        if text_id == 0:
            out.append(AssembledText(severity, text, True, 1))
            return out
        if not 0 <= chunk_seq < MAX_CHUNKS:
            return out
        key = (sysid, compid, text_id)
        pending = self._pending.get(key)
        if pending is None:
            if len(self._pending) >= self.max_pending:
                oldest = min(self._pending, key=lambda k: self._pending[k].first_rx_s)
                out.append(self._emit(self._pending.pop(oldest)))
            pending = self._pending[key] = _PendingText(severity, now_s)
        pending.chunks[chunk_seq] = text
        if len(text) < CHUNK_CHARS:
            pending.last_seq = chunk_seq
        if pending.last_seq is not None and len(pending.chunks) == pending.last_seq + 1:
            out.append(self._emit(self._pending.pop(key)))
        return out

    def expire(self, now_s: float) -> list[AssembledText]:
        """Texts held longer than ``timeout_s``: emitted as they are (incomplete)."""
        old = [k for k, p in self._pending.items() if now_s - p.first_rx_s >= self.timeout_s]
        return [self._emit(self._pending.pop(k)) for k in old]

    @staticmethod
    def _emit(p: _PendingText) -> AssembledText:
        last = p.last_seq if p.last_seq is not None else max(p.chunks)
        parts = [p.chunks.get(seq, MISSING_MARK) for seq in range(last + 1)]
        complete = p.last_seq is not None and all(seq in p.chunks for seq in range(last + 1))
        if p.last_seq is None:
            parts.append(MISSING_MARK)  # the end never came
        return AssembledText(p.severity, "".join(parts), complete, len(p.chunks))
