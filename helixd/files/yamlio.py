"""Reading YAML that may be hostile: the one loader for config, mission and simulator files.

What it refuses, and how (each stage runs only on what passed the one before):

1. **Size**: at most :data:`MAX_FILE_BYTES` are read (``/dev/zero`` or a 2 GB file is refused
   after reading one byte more than the cap, never slurped).
2. **Encoding**: strict UTF-8; the offset of the first bad byte is named.
3. **Parsing** is libyaml's (``yaml.parse`` with ``CParser`` when PyYAML was built with it,
   else PyYAML's pure-Python parser, same events). The document is built in ONE pass over the
   *event stream*, iteratively (an explicit stack, no recursion), and that pass refuses:
   ``*alias`` at once (a 900-byte "billion laughs" never expands), nesting deeper than
   :data:`MAX_DEPTH` at the first event past it (5 000 ``[`` cannot reach a recursion limit or
   the C stack), duplicate keys naming both lines, explicit tags (``!!python/object``…),
   merge keys, complex keys, a second document, integers longer than 40 digits, and more than
   :data:`MAX_EVENTS` values (so memory stays bounded: a 16 MB ``[1,1,1,…]`` is refused
   after a million values instead of building eight million objects).
4. **Scalars** follow the YAML 1.2 core schema, not YAML 1.1: only ``true``/``false`` are
   booleans (``yes``/``no``/``on``/``off`` stay text, so ``x: yes`` can never become 1.0 and
   ``name: no`` stays the string ``no``); no sexagesimal ``1:30`` = 90, ``010`` is ten, no
   timestamps. Quoted scalars are always text.

Why this design: PyYAML's libyaml binding is already a dependency and is the fastest
maintained parser available here. Its C *composer* is not the fast part: it calls the Python
resolver for every scalar and builds a node graph (4.8 s for a 100 000-waypoint mission on the
development machine, 6.6 s with construction), and it sees aliases/depth only after composing.
Consuming the C parser's events directly costs about 0.8 s for the same file and lets every
refusal happen before anything is built; the builder is ~60 lines and parses nothing itself.
ruamel.yaml (duplicate keys refused, but slower, still expands aliases) and strictyaml (no
aliases/flow style, but pure Python — far too slow for 100 000 points — and a second schema
language next to pydantic) were the alternatives.

Every message is one line and quotes values through :func:`clip`, so a hostile value can never
produce a 10 MB error message.
"""

from __future__ import annotations

import contextlib
import gc
import math
import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import yaml

MAX_FILE_BYTES = 16 * 1024 * 1024  # a 100 000-waypoint mission is about 2.5 MB
MAX_DEPTH = 32  # deepest real config nesting is 5 (sim terrain table); missions use 3
NESTING_REFUSAL = "exceeded maximum nesting depth"  # PyYAML's own limit's message (>= 6.0.4)
MAX_EVENTS = 1_000_000  # parser events (values + collections); 100 000 waypoints are ~600 000
MAX_SHOWN_CHARS = 120  # longest quoted value in a message
MAX_LINE_CHARS = 400  # longest problem line (of what came from the input)
MAX_NUMBER_CHARS = 40  # longest number text a file may hold (a float64 needs 24)
# longest line an operator is shown: the clipped part from the input, plus what helixd adds
# whole (e.g. every allowed key of the largest config section)
MAX_ERROR_LINE_CHARS = 2000

try:
    _BaseLoader: type[yaml.SafeLoader] = yaml.CSafeLoader  # type: ignore[assignment]
    LIBYAML = True
except AttributeError:  # pragma: no cover - PyYAML built without libyaml
    _BaseLoader = yaml.SafeLoader
    LIBYAML = False


class YamlFileError(Exception):
    """The file is not usable YAML. ``message`` is one line, starting with the file name."""

    def __init__(self, path: Path | str, message: str) -> None:
        self.path = Path(path)
        self.message = clip_line(message)
        super().__init__(self.message)


def clip(value: Any, limit: int = MAX_SHOWN_CHARS) -> str:
    """``repr(value)`` cut to ``limit`` characters; never raises (huge ints, odd objects)."""
    try:
        text = repr(value)
    except Exception:  # e.g. int with more digits than sys.get_int_max_str_digits()
        text = f"<{type(value).__name__} too large to show>"
    if len(text) > limit:
        text = f"{text[: limit - 1]}… ({len(text)} characters)"
    return text


def clip_line(line: str, limit: int = MAX_LINE_CHARS) -> str:
    """One line, at most ``limit`` characters."""
    line = " ".join(line.split())
    if len(line) > limit:
        line = line[: limit - 1] + "…"
    return line


def finite_number(text: str, what: str) -> float:
    """``text`` (a column or value of a text file) as a finite number; ValueError naming
    ``what`` and the text otherwise. A text longer than :data:`MAX_NUMBER_CHARS` is no number
    any of our files writes, and is refused before it is parsed."""
    try:
        if len(text) > MAX_NUMBER_CHARS:
            raise ValueError
        value = float(text)
    except ValueError:
        raise ValueError(f"{what} {clip(text, MAX_NUMBER_CHARS)} is not a number") from None
    if not math.isfinite(value):
        raise ValueError(f"{what} {clip(text, MAX_NUMBER_CHARS)} is not a finite number")
    return value


# ---------------------------------------------------------------------------------------------
# The loader: YAML 1.2-like core schema, duplicate keys refused


class _DuplicateKey(yaml.YAMLError):
    def __init__(self, key: Any, first_line: int, second_line: int) -> None:
        where = (
            f"twice on line {first_line}"
            if first_line == second_line
            else f"at lines {first_line} and {second_line}"
        )
        self.text = f"duplicate key {clip(key)} {where} (each key may appear once)"
        super().__init__(self.text)


class _YamlRefused(yaml.YAMLError):
    def __init__(self, text: str) -> None:
        self.text = text
        super().__init__(text)


_NULL_RE = re.compile(r"^(?:~|null|Null|NULL|)$")
_BOOL = {"true": True, "True": True, "TRUE": True, "false": False, "False": False, "FALSE": False}
_INT_RE = re.compile(r"^[-+]?(?:[0-9][0-9_]*|0x[0-9a-fA-F_]+|0o[0-7_]+)$")
_FLOAT_RE = re.compile(
    r"^[-+]?(?:\.[0-9]+|[0-9][0-9_]*(?:\.[0-9_]*)?)(?:[eE][-+]?[0-9]+)?$"
    r"|^[-+]?\.(?:inf|Inf|INF)$|^\.(?:nan|NaN|NAN)$"
)
_DECIMAL_RE = re.compile(r"-?[0-9]+\.[0-9]+\Z")  # subset of _FLOAT_RE, float() reads it alike
_STR_TAGS = (None, "!", "tag:yaml.org,2002:str")
_MAX_DIGITS = 40  # far beyond any field's range; also keeps int() cheap and its repr printable


def _line(event: Any) -> int:
    mark = event.start_mark
    return int(mark.line) + 1 if mark is not None else 0


def _plain_scalar(value: str, event: Any) -> Any:
    """YAML 1.2 core schema for a plain (unquoted) scalar."""
    if (not value or value[0] in "~nN") and _NULL_RE.match(value):
        return None
    if value in _BOOL:
        return _BOOL[value]
    if value[0] in "-+.0123456789":
        if _INT_RE.match(value):
            text = value.replace("_", "")
            body = text.lstrip("+-")
            if len(body) > _MAX_DIGITS:
                raise _YamlRefused(
                    f"number at line {_line(event)} has {len(body)} digits (at most {_MAX_DIGITS})"
                )
            sign = -1 if text[0] == "-" else 1
            base = 0 if body[:2] in ("0x", "0o") else 10  # YAML 1.2: 010 is ten, not eight
            return sign * int(body, base)
        if _FLOAT_RE.match(value):
            text = value.replace("_", "").lower()
            if text.endswith(".inf"):
                return float("-inf") if text[0] == "-" else float("inf")
            if text.endswith(".nan"):
                return float("nan")
            return float(text)
    return value


def _scalar(event: Any) -> Any:
    tag = event.tag
    if tag not in _STR_TAGS:
        raise _YamlRefused(f"explicit tag {clip(tag, 60)} at line {_line(event)} is not allowed")
    if not event.style and tag is None and event.implicit[0]:  # plain: C gives "", Python None
        return _plain_scalar(event.value, event)
    return event.value


_NO_KEY = object()


class _Container:
    __slots__ = ("key", "marks", "obj")

    def __init__(self, obj: dict[Any, Any] | list[Any]) -> None:
        self.obj = obj
        self.key: Any = _NO_KEY
        self.marks: dict[Any, Any] = {}  # key → its start mark (line computed on error only)


def _build(text: str) -> Any:
    """One pass over libyaml's events: refuse aliases, tags, depth, duplicate keys and extra
    documents; build plain dicts/lists/scalars. Iterative: nesting costs no recursion."""
    stack: list[_Container] = []
    root: Any = None
    documents = 0
    event: Any
    # local names: this loop runs once per event (600 000 for 100 000 waypoints)
    scalar_event, mapping_start, sequence_start = (
        yaml.ScalarEvent,
        yaml.MappingStartEvent,
        yaml.SequenceStartEvent,
    )
    mapping_end, sequence_end = yaml.MappingEndEvent, yaml.SequenceEndEvent
    decimal, to_float, no_key, max_events = _DECIMAL_RE.match, float, _NO_KEY, MAX_EVENTS
    for count, event in enumerate(yaml.parse(text, Loader=_BaseLoader)):
        if count >= max_events:
            raise _YamlRefused(
                f"more than {MAX_EVENTS} values by line {_line(event)}; refused (split the file)"
            )
        kind = type(event)
        if kind is scalar_event:
            raw = event.value
            if event.tag is None and not event.style and decimal(raw):
                value: Any = to_float(raw)  # fast path: most of a mission is plain decimals
            else:
                value = _scalar(event)
        elif kind is mapping_start or kind is sequence_start:
            if len(stack) >= MAX_DEPTH:
                raise _YamlRefused(f"nested deeper than {MAX_DEPTH} levels at line {_line(event)}")
            if event.tag not in (None, "!"):
                raise _YamlRefused(
                    f"explicit tag {clip(event.tag, 60)} at line {_line(event)} is not allowed"
                )
            stack.append(_Container({} if kind is mapping_start else []))
            continue
        elif kind is mapping_end or kind is sequence_end:
            value = stack.pop().obj
        elif kind is yaml.AliasEvent:
            raise _YamlRefused(
                f"alias *{clip(event.anchor, 40)[1:-1]} at line {_line(event)}: aliases "
                "(&anchor/*alias) are not allowed; write the value out"
            )
        elif kind is yaml.DocumentStartEvent:
            documents += 1
            if documents > 1:
                raise _YamlRefused(f"a second YAML document at line {_line(event)}; one per file")
            continue
        else:  # stream start/end, document end
            continue
        if not stack:
            root = value
            continue
        top = stack[-1]
        obj = top.obj
        if type(obj) is list:
            obj.append(value)
        elif top.key is no_key:
            if isinstance(value, (dict, list)):
                raise _YamlRefused(f"a list or mapping used as a key at line {_line(event)}")
            if value == "<<" and kind is scalar_event and not event.style:
                raise _YamlRefused(f"merge key '<<' at line {_line(event)} is not supported")
            if value in top.marks:
                first = top.marks[value]
                raise _DuplicateKey(value, int(first.line) + 1 if first else 0, _line(event))
            top.marks[value] = event.start_mark
            top.key = value
        else:
            obj[top.key] = value
            top.key = no_key
    return root


def _yaml_problem(exc: yaml.YAMLError, text: str | None = None) -> str:
    if isinstance(exc, (_YamlRefused, _DuplicateKey)):
        return exc.text
    mark = getattr(exc, "problem_mark", None)
    where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
    reason = getattr(exc, "problem", None) or str(exc).splitlines()[0]
    if NESTING_REFUSAL in reason and mark is not None:
        # PyYAML >= 6.0.4 scans a flow collection's tokens ahead of its events and stops at
        # its own depth limit (1 000) before the parser hands over the event past ours
        return f"nested deeper than {MAX_DEPTH} levels at line {mark.line + 1}"
    if mark is not None and text is not None:
        lines = text.splitlines()
        row = lines[mark.line] if mark.line < len(lines) else ""
        if "\t" in row[: mark.column + 1]:
            reason += " (a tab: YAML is indented with spaces only)"
    return f"not valid YAML{where}: {reason}"


def parse_yaml_text(text: str, source: Path | str = "<text>") -> Any:
    """Parse one YAML document with every check above; raise :class:`YamlFileError`."""
    try:
        with paused_gc():
            return _build(text)
    except yaml.YAMLError as exc:
        raise YamlFileError(source, f"{source}: {_yaml_problem(exc, text)}") from None
    except (ValueError, OverflowError, RecursionError, MemoryError) as exc:
        # int()/float() of a malformed number, or anything the constructors did not expect
        reason = clip_line(str(exc), 160)
        raise YamlFileError(source, f"{source}: not valid YAML: {reason}") from None


@contextlib.contextmanager
def paused_gc() -> Iterator[None]:
    """Pause the cyclic garbage collector while building large acyclic data (a 100 000-waypoint
    mission allocates ~10^6 objects; the collector's passes over them cost more than the
    parse). Reference counting still frees everything; the previous state is restored."""
    was_enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was_enabled:
            gc.enable()


def read_text_capped(path: Path | str, max_bytes: int = MAX_FILE_BYTES) -> str:
    """The file's text, refusing files over ``max_bytes`` and anything that is not UTF-8."""
    p = Path(path)
    try:
        with p.open("rb") as fh:
            data = fh.read(max_bytes + 1)
    except FileNotFoundError:
        raise YamlFileError(p, f"{p}: file not found") from None
    except IsADirectoryError:
        raise YamlFileError(p, f"{p}: is a directory, not a YAML file") from None
    except OSError as exc:
        raise YamlFileError(p, f"{p}: cannot read file: {exc.strerror or exc}") from None
    if len(data) > max_bytes:
        raise YamlFileError(
            p,
            f"{p}: file larger than {max_bytes // (1024 * 1024)} MB; refused "
            "(is it the right file?)",
        )
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise YamlFileError(
            p, f"{p}: not UTF-8 text (bad byte 0x{data[exc.start]:02x} at offset {exc.start})"
        ) from None


def load_yaml_file(path: Path | str, max_bytes: int = MAX_FILE_BYTES) -> Any:
    """Read and parse ``path``; the result is plain dicts/lists/str/int/float/bool/None."""
    return parse_yaml_text(read_text_capped(path, max_bytes), path)


__all__ = [
    "LIBYAML",
    "MAX_DEPTH",
    "MAX_EVENTS",
    "MAX_FILE_BYTES",
    "YamlFileError",
    "clip",
    "clip_line",
    "load_yaml_file",
    "parse_yaml_text",
    "paused_gc",
    "read_text_capped",
]
