"""The hostile-JSON reader (.plan, GeoJSON): bounded nesting, no NaN/Infinity literals, no
number overflowing to infinity, no duplicate keys; every problem is one line naming the source.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

from helixd.files.yamlio import clip, clip_line

MAX_JSON_DEPTH = 24  # deeper than any file helixd reads (a .plan nests 6 deep)


class JsonTextError(ValueError):
    """The text is not usable JSON. ``message`` is one line, starting with the source's name."""

    def __init__(self, message: str) -> None:
        self.message = clip_line(message)
        super().__init__(self.message)


def _refuse_constant(name: str) -> Any:
    raise ValueError(f"{name} is not a number JSON allows (write a finite number)")


def _parse_float(text: str) -> float:
    value = float(text)
    if not math.isfinite(value):
        raise ValueError(f"number {clip(text, 40)} overflows to infinity")
    return value


def _no_duplicates(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for k, v in pairs:
        if k in out:
            raise ValueError(
                f"duplicate key {clip(k, 60)} in one object (each key may appear once)"
            )
        out[k] = v
    return out


def _depth_ok(text: str, max_depth: int) -> int:
    """Deepest bracket nesting outside strings (cheap scan, so json never recurses deeply)."""
    depth = deepest = 0
    in_str = esc = False
    for ch in text:
        if in_str:
            if esc:
                esc = False
            elif ch == "\\":
                esc = True
            elif ch == '"':
                in_str = False
        elif ch == '"':
            in_str = True
        elif ch in "[{":
            depth += 1
            if depth > deepest:
                deepest = depth
                if deepest > max_depth:
                    return deepest
        elif ch in "]}":
            depth -= 1
    return deepest


def load_json_text(
    text: str, source: Path | str, kind: str = "", max_depth: int = MAX_JSON_DEPTH
) -> Any:
    """Parse hostile JSON: bounded depth, no NaN/Infinity, no overflow, no duplicate keys.

    ``kind`` (e.g. ``".plan"``) names what the file should have been in the errors."""
    src = str(source)
    if _depth_ok(text, max_depth) > max_depth:
        tail = f"; not a {kind}" if kind else ""
        raise JsonTextError(f"{src}: JSON nested deeper than {max_depth} levels{tail}")
    usable = f"a usable {kind}" if kind else "usable JSON"
    try:
        return json.loads(
            text,
            parse_constant=_refuse_constant,
            parse_float=_parse_float,
            object_pairs_hook=_no_duplicates,
        )
    except json.JSONDecodeError as exc:
        raise JsonTextError(
            f"{src}: not valid JSON at line {exc.lineno}, column {exc.colno}: {exc.msg}"
        ) from None
    except (ValueError, RecursionError) as exc:
        raise JsonTextError(f"{src}: not {usable}: {exc}") from None
