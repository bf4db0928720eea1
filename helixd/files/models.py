"""The strict-model machinery every file helixd reads is validated with: pydantic bases that
refuse unknown keys, booleans-as-numbers and (for inputs) NaN/±inf; one error type carrying
one line per problem that names the file, the dotted field, the bad value and the allowed
range; and the YAML-file-to-model loader. The config, the mission models, the simulator's
config and the recorder's summary build on it.
"""

from __future__ import annotations

import difflib
import math
import re
from functools import cache
from pathlib import Path
from typing import Any, TypeVar

from pydantic import BaseModel, ConfigDict, ValidationError, model_validator

from helixd.files.yamlio import YamlFileError, clip, clip_line, load_yaml_file, paused_gc

# ---------------------------------------------------------------------------------------------
# Base models and error reporting


def _accepts_bool_uncached(annotation: Any) -> bool:
    if annotation is bool:
        return True
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return True
    return any(_accepts_bool(arg) for arg in getattr(annotation, "__args__", ()))


_accepts_bool_cached = cache(_accepts_bool_uncached)


def _accepts_bool(annotation: Any) -> bool:
    """True if ``annotation`` mentions bool or a nested model (which checks its own fields)."""
    try:
        return _accepts_bool_cached(annotation)
    except TypeError:  # an unhashable annotation: just compute it
        return _accepts_bool_uncached(annotation)


def _contains_bool(value: Any) -> bool:
    if type(value) is bool:
        return True
    if isinstance(value, (list, tuple)):
        return any(_contains_bool(v) for v in value)
    if isinstance(value, dict):
        return any(_contains_bool(v) for v in value.values())
    return False


class StrictModel(BaseModel):
    """Base for every config/mission model: unknown keys are errors, values are immutable.

    A boolean is never a number: pydantic's lax mode would read ``true`` as 1.0 for a float
    field (and YAML 1.1 read ``yes`` as true); here a bool anywhere in a field that is not
    declared bool is an error.
    """

    model_config = ConfigDict(extra="forbid", frozen=True, validate_default=True)

    @model_validator(mode="before")
    @classmethod
    def _no_bool_as_number(cls, data: Any) -> Any:
        # One call per model (not per field): 100 000 waypoints stay fast.
        if not isinstance(data, dict):
            return data
        bad: list[str] = []
        for key, value in data.items():
            kind = type(value)
            if kind is not bool and kind is not list and kind is not dict and kind is not tuple:
                continue  # fast path: plain scalars
            field = cls.model_fields.get(key)
            if field is not None and not _accepts_bool(field.annotation) and _contains_bool(value):
                bad.append(str(key))
        if bad:
            raise ValueError(
                f"{', '.join(bad)}: true/false is not a number (write the number itself; "
                "yes/no/on/off are not numbers either)"
            )
        return data


class InputModel(StrictModel):
    """Config and mission models: additionally NaN and ±infinity are refused everywhere."""

    model_config = ConfigDict(allow_inf_nan=False)


class ConfigFileError(Exception):
    """A configuration or mission file could not be used. ``problems`` holds one line each."""

    def __init__(self, path: Path | str, problems: list[str]) -> None:
        self.path = Path(path)
        self.problems = problems
        super().__init__("\n".join(problems))


_BOUND_WORDS = {
    "greater_than": "> {gt}",
    "greater_than_equal": ">= {ge}",
    "less_than": "< {lt}",
    "less_than_equal": "<= {le}",
}


_TYPE_WORDS = {
    "float": "allowed: a number",
    "int": "allowed: a whole number",
    "bool": "allowed: true or false",
    "string": "allowed: text",
    "list": "allowed: a list",
    "tuple": "allowed: a list",
    "dict": "allowed: a mapping of keys",
    "model": "allowed: a mapping of keys",
}


def _model_at(model: type[BaseModel], loc: tuple[int | str, ...]) -> type[BaseModel] | None:
    """Walk ``loc`` through nested pydantic models; return the model owning the last key."""
    current: Any = model
    for part in loc[:-1]:
        if isinstance(part, int):
            continue
        if not (isinstance(current, type) and issubclass(current, BaseModel)):
            return None
        field = current.model_fields.get(str(part))
        if field is None:
            return None
        current = _inner_model(field.annotation)
    if isinstance(current, type) and issubclass(current, BaseModel):
        return current
    return None


def _inner_model(annotation: Any) -> Any:
    """Find a BaseModel inside Optional[...] / list[...] / tuple[...] annotations."""
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return annotation
    for arg in getattr(annotation, "__args__", ()):
        found = _inner_model(arg)
        if found is not None:
            return found
    return None


_Bound = tuple[Any, bool] | None  # (value, inclusive)


def _bounds(metadata: Any) -> tuple[_Bound, _Bound]:
    lo: _Bound = None
    hi: _Bound = None
    for meta in metadata:
        for inner in (meta, *getattr(meta, "metadata", ())):
            for name, inclusive in (("ge", True), ("gt", False)):
                value = getattr(inner, name, None)
                if lo is None and value is not None:
                    lo = (value, inclusive)
            for name, inclusive in (("le", True), ("lt", False)):
                value = getattr(inner, name, None)
                if hi is None and value is not None:
                    hi = (value, inclusive)
    return lo, hi


def _item_bounds(annotation: Any) -> tuple[_Bound, _Bound]:
    for arg in getattr(annotation, "__args__", ()):
        lo, hi = _bounds(getattr(arg, "__metadata__", ()))
        if lo is not None and hi is not None:
            return lo, hi
    return None, None


def range_text(lo: tuple[Any, bool], hi: tuple[Any, bool]) -> str:
    """The allowed range, exact: ``allowed range 1 .. 18`` when both ends are allowed,
    otherwise each end with its own operator (``allowed: > 0.0 and <= 5.0``)."""
    (low, low_in), (high, high_in) = lo, hi
    if low_in and high_in:
        return f"allowed range {low} .. {high}"
    return f"allowed: {'>=' if low_in else '>'} {low} and {'<=' if high_in else '<'} {high}"


def _allowed_text(err: Any, model: type[BaseModel], loc: tuple[int | str, ...]) -> str:
    etype = err["type"]
    ctx = err.get("ctx") or {}
    if etype in _BOUND_WORDS:
        bound = _BOUND_WORDS[etype].format(**ctx)
        owner = _model_at(model, loc)
        if owner is not None and loc and isinstance(loc[-1], str):
            field = owner.model_fields.get(loc[-1])
            if field is not None:
                lo, hi = _bounds(field.metadata)
                if lo is not None and hi is not None:
                    return range_text(lo, hi)
        if len(loc) >= 2 and isinstance(loc[-1], int) and isinstance(loc[-2], str):
            # an item of a list field such as stick_channels: bounds sit on the item type
            owner = _model_at(model, loc[:-1])
            field = owner.model_fields.get(loc[-2]) if owner is not None else None
            if field is not None:
                lo, hi = _item_bounds(field.annotation)
                if lo is not None and hi is not None:
                    return range_text(lo, hi)
        return f"allowed: {bound}"
    if etype == "extra_forbidden":
        owner = _model_at(model, loc)
        if owner is not None:
            fields = sorted(owner.model_fields)
            key = loc[-1] if loc and isinstance(loc[-1], str) else None
            near = difflib.get_close_matches(key, fields, n=1) if key is not None else []
            hint = f"did you mean {near[0]}? " if near else ""
            return hint + "allowed keys here: " + ", ".join(fields)
        return "remove it"
    if etype in ("enum", "literal_error"):
        return "allowed: " + str(ctx.get("expected", "see the documentation"))
    if etype == "missing":
        return "this field is required"
    return _TYPE_WORDS.get(etype.split("_")[0], "")


_YAML11_BOOLS = frozenset({"yes", "no", "on", "off", "y", "n"})


ENTRY_LIST = "waypoints"  # the mission's list of entries, numbered for people from 1
_ENTRY_RE = re.compile(r"waypoint (\d+) \(waypoints\[\d+\]\)")


def entry_label(index: int) -> str:
    """How an error names the mission entry at 0-based ``index``: counted from 1 as a person
    (and a ground station) counts it, the YAML list path beside it: ``waypoint 1
    (waypoints[0])``. A ground-station file's errors say ``item 1`` instead
    (:func:`as_items`)."""
    return f"waypoint {index + 1} ({ENTRY_LIST}[{index}])"


def as_items(text: str) -> str:
    """An error about a ground-station file (QGroundControl ``.plan``, WPL 110
    ``.waypoints``, the autopilot's mission): its entries named by their mission item, the
    sequence number the ground station shows (home 0, the first item 1): ``item 1``."""
    return _ENTRY_RE.sub(r"item \1", text)


def _dotted(loc: tuple[int | str, ...]) -> str:
    """A pydantic error path as the operator reads it: ``waypoint 1 (waypoints[0]): q`` for
    ``waypoints.0.q``, the dotted path (``keep_out_polygons.0``) elsewhere."""
    if len(loc) >= 2 and loc[0] == ENTRY_LIST and isinstance(loc[1], int):
        rest = ".".join(str(p) for p in loc[2:])
        return entry_label(loc[1]) + (f": {rest}" if rest else "")
    return ".".join(str(p) for p in loc) if loc else "(top level)"


def format_validation_error(
    path: Path | str, exc: ValidationError, model: type[BaseModel]
) -> list[str]:
    """One human line per pydantic error: ``file: dotted.path: problem (got X; allowed Y)``."""
    lines: list[str] = []
    for err in exc.errors(include_url=False):
        loc = tuple(err["loc"])
        dotted = _dotted(loc)
        etype = err["type"]
        if etype == "extra_forbidden":
            problem = "unknown key"
        elif etype == "missing":
            problem = "missing required field"
        else:
            problem = str(err["msg"]).removeprefix("Value error, ")
        value = err.get("input")
        shown = etype != "missing" and not isinstance(value, dict)
        got = f" (got {clip(value)}" if shown else ""
        # what helixd adds (allowed keys, ranges, hints) is never cut: only what came from
        # the file (key names, values) is, so a long list of allowed keys stays whole
        ours: list[str] = []
        if not etype.startswith("value_error"):
            allowed = _allowed_text(err, model, loc)
            if allowed:
                ours.append(allowed)
        if etype == "value_error" and (not loc or "\n" in problem):
            # a cross-field validator: one line per problem, each naming its fields itself
            prefix = f"{path}: {dotted}: " if loc else f"{path}: "
            lines.extend(clip_line(prefix + p) for p in problem.splitlines() if p)
            continue
        if isinstance(value, str) and value.lower() in _YAML11_BOOLS and "parsing" in etype:
            ours.append("yes/no/on/off are text, not numbers or switches: write the number")
        head = clip_line(f"{path}: {dotted}: {problem}{got}")
        if ours:
            tail = "; ".join(ours) + ")"
            lines.append(f"{head}; {tail}" if got else f"{head} ({tail}")
        else:
            lines.append(f"{head})" if got else head)
    return lines


M = TypeVar("M", bound=BaseModel)


def load_yaml_model(path: Path | str, model: type[M], context: dict[str, Any] | None = None) -> M:
    """Read ``path`` as YAML and validate it as ``model``; raise ConfigFileError otherwise."""
    p = Path(path)
    try:
        data = load_yaml_file(p)
    except YamlFileError as exc:
        raise ConfigFileError(p, [exc.message]) from None
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise ConfigFileError(
            p, [f"{p}: (top level): expected a mapping of keys, got {type(data).__name__}"]
        )
    try:
        with paused_gc():
            return model.model_validate(data, context=context)
    except ValidationError as exc:
        raise ConfigFileError(p, format_validation_error(p, exc, model)) from None


def finite(value: float) -> float:
    if not math.isfinite(value):
        raise ValueError("must be a finite number")
    return value
