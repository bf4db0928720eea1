"""Reading YAML that may be hostile: the one loader for config, mission and simulator files.

What it refuses, and how (each check happens before the next stage runs):

1. **Size**: at most :data:`MAX_FILE_BYTES` are read (``/dev/zero`` or a 2 GB file is refused
   after reading one byte more than the cap, never slurped).
2. **Encoding**: strict UTF-8; the byte offset of the first bad byte is named.
3. **Aliases and depth**, on libyaml's *event stream* (``yaml.parse``): an ``*alias`` is refused
   at once (a 900-byte "billion laughs" never expands), and nesting deeper than
   :data:`MAX_DEPTH` is refused at the first event past it. The libyaml parser keeps its own
   explicit stack, so 5 000 ``[`` cannot blow Python's recursion limit or the C stack; the
   (recursive) composer only ever sees a document that passed this scan.
4. **Construction** with ``yaml.CSafeLoader`` (libyaml, C) where available, else ``SafeLoader``,
   with a YAML 1.2-style core schema instead of YAML 1.1's: only ``true``/``false`` are
   booleans (``yes``/``no``/``on``/``off`` stay text, so ``x: yes`` can never become 1.0 and
   ``name: no`` stays the string ``no``), no sexagesimal ``1:30`` = 90, no leading-zero octal,
   no timestamps, no merge keys. Duplicate mapping keys are refused naming both line numbers.

Why this design: PyYAML is already a dependency and its libyaml binding is the fastest maintained
parser available here (a 100 000-waypoint mission loads in about a second). ruamel.yaml detects
duplicate keys but is slower, pure Python in its round-trip mode and still expands aliases;
strictyaml refuses aliases and flow style but is pure Python (far too slow for 100 000 points)
and brings its own schema language next to pydantic. Everything here is PyYAML public API
(``yaml.parse`` events, ``Loader`` subclass, ``add_implicit_resolver``/``add_constructor``);
no YAML is parsed by hand.

Every message is one line and quotes values through :func:`clip`, so a hostile value can never
produce a 10 MB error message.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any, ClassVar

import yaml
from yaml.nodes import MappingNode, Node, ScalarNode

MAX_FILE_BYTES = 16 * 1024 * 1024  # a 100 000-waypoint mission is about 2.5 MB
MAX_DEPTH = 32  # deepest real config nesting is 5 (sim terrain table); missions use 3
MAX_SHOWN_CHARS = 120  # longest quoted value in a message
MAX_LINE_CHARS = 400  # longest problem line

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


# ---------------------------------------------------------------------------------------------
# The loader: YAML 1.2-like core schema, duplicate keys refused


class _DuplicateKey(yaml.YAMLError):
    def __init__(self, key: Any, first_line: int, second_line: int) -> None:
        self.text = (
            f"duplicate key {clip(key)} at lines {first_line} and {second_line} "
            "(each key may appear once)"
        )
        super().__init__(self.text)


class _Refused(yaml.YAMLError):
    def __init__(self, text: str) -> None:
        self.text = text
        super().__init__(text)


class StrictLoader(_BaseLoader):  # type: ignore[misc,valid-type]
    """Safe loader with a YAML 1.2-like core schema and duplicate-key detection."""

    yaml_implicit_resolvers: ClassVar[dict[str | None, list[tuple[str, re.Pattern[str]]]]] = {}
    yaml_constructors: ClassVar[dict[Any, Any]] = dict(yaml.SafeLoader.yaml_constructors)

    def construct_mapping(self, node: Node, deep: bool = False) -> dict[Any, Any]:
        if not isinstance(node, MappingNode):
            raise _Refused(f"expected a mapping at line {node.start_mark.line + 1}")
        seen: dict[Any, int] = {}
        out: dict[Any, Any] = {}
        for key_node, value_node in node.value:
            line = key_node.start_mark.line + 1
            if key_node.tag == "tag:yaml.org,2002:merge":
                raise _Refused(f"merge key '<<' at line {line} is not supported")
            key = self.construct_object(key_node, deep=True)
            try:
                hash(key)
            except TypeError:
                raise _Refused(f"a list or mapping used as a key at line {line}") from None
            if key in seen:
                raise _DuplicateKey(key, seen[key], line)
            seen[key] = line
            out[key] = self.construct_object(value_node, deep=deep)
        return out

    def construct_core_int(self, node: ScalarNode) -> int:
        text = str(self.construct_scalar(node)).replace("_", "")
        sign = -1 if text.startswith("-") else 1
        body = text.lstrip("+-")
        if len(body) > 40:  # far beyond any field's range; also keeps int() cheap
            raise _Refused(
                f"number at line {node.start_mark.line + 1} has {len(body)} digits "
                "(at most 40 allowed)"
            )
        if body[:2] in ("0x", "0o"):
            return sign * int(body, 0)
        return sign * int(body, 10)  # YAML 1.2: 010 is ten, not octal eight

    def construct_core_float(self, node: ScalarNode) -> float:
        text = str(self.construct_scalar(node)).replace("_", "").lower()
        if text.endswith(".inf"):
            return float("-inf") if text.startswith("-") else float("inf")
        if text.endswith(".nan"):
            return float("nan")
        return float(text)


def _core_schema() -> None:
    add = StrictLoader.add_implicit_resolver
    add(
        "tag:yaml.org,2002:null",
        re.compile(r"^(?:~|null|Null|NULL|)$"),
        ["~", "n", "N", ""],
    )
    add(
        "tag:yaml.org,2002:bool",
        re.compile(r"^(?:true|True|TRUE|false|False|FALSE)$"),
        list("tTfF"),
    )
    add(
        "tag:yaml.org,2002:int",
        re.compile(r"^(?:[-+]?[0-9][0-9_]*|0x[0-9a-fA-F_]+|0o[0-7_]+)$"),
        list("-+0123456789"),
    )
    add(
        "tag:yaml.org,2002:float",
        re.compile(
            r"^(?:[-+]?(?:\.[0-9]+|[0-9][0-9_]*(?:\.[0-9_]*)?)(?:[eE][-+]?[0-9]+)?"
            r"|[-+]?\.(?:inf|Inf|INF)|\.(?:nan|NaN|NAN))$"
        ),
        list("-+.0123456789"),
    )
    StrictLoader.add_constructor("tag:yaml.org,2002:int", StrictLoader.construct_core_int)
    StrictLoader.add_constructor("tag:yaml.org,2002:float", StrictLoader.construct_core_float)
    for tag in ("timestamp", "binary", "omap", "pairs", "set", "merge"):
        StrictLoader.yaml_constructors.pop(f"tag:yaml.org,2002:{tag}", None)


_core_schema()


# ---------------------------------------------------------------------------------------------
# Event scan: aliases and depth, before anything is composed


def _scan_events(text: str) -> None:
    depth = 0
    for event in yaml.parse(text, Loader=_BaseLoader):
        if isinstance(event, yaml.AliasEvent):
            line = event.start_mark.line + 1 if event.start_mark else 0
            raise _Refused(
                f"alias *{clip(event.anchor, 40)[1:-1]} at line {line}: aliases (&anchor/*alias) "
                "are not allowed; write the value out"
            )
        if isinstance(event, yaml.CollectionStartEvent):
            depth += 1
            if depth > MAX_DEPTH:
                line = event.start_mark.line + 1 if event.start_mark else 0
                raise _Refused(f"nested deeper than {MAX_DEPTH} levels at line {line}")
        elif isinstance(event, (yaml.MappingEndEvent, yaml.SequenceEndEvent)):
            depth -= 1


def _yaml_problem(exc: yaml.YAMLError, text: str | None = None) -> str:
    if isinstance(exc, (_Refused, _DuplicateKey)):
        return exc.text
    mark = getattr(exc, "problem_mark", None)
    where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
    reason = getattr(exc, "problem", None) or str(exc).splitlines()[0]
    if mark is not None and text is not None:
        lines = text.splitlines()
        row = lines[mark.line] if mark.line < len(lines) else ""
        if "\t" in row[: mark.column + 1]:
            reason += " (a tab: YAML is indented with spaces only)"
    return f"not valid YAML{where}: {reason}"


def parse_yaml_text(text: str, source: Path | str = "<text>") -> Any:
    """Parse one YAML document with every check above; raise :class:`YamlFileError`."""
    try:
        _scan_events(text)
        return yaml.load(text, Loader=StrictLoader)  # StrictLoader is a SafeLoader
    except yaml.YAMLError as exc:
        raise YamlFileError(source, f"{source}: {_yaml_problem(exc, text)}") from None
    except (ValueError, OverflowError, RecursionError, MemoryError) as exc:
        # int()/float() of a malformed number, or anything the constructors did not expect
        reason = clip_line(str(exc), 160)
        raise YamlFileError(source, f"{source}: not valid YAML: {reason}") from None


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
    "MAX_FILE_BYTES",
    "StrictLoader",
    "YamlFileError",
    "clip",
    "clip_line",
    "load_yaml_file",
    "parse_yaml_text",
    "read_text_capped",
]
