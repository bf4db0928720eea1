"""Every config field keeps its description, a bound on each side and a default, and the
description is the docstring written under the field (helixd.config.fields.ConfigSection)."""

from __future__ import annotations

import types
import typing

from annotated_types import Ge, Gt, Le, Lt
from pydantic import BaseModel, Field
from pydantic.fields import FieldInfo

from helixd.config.fields import ConfigSection
from helixd.config.link import LinkConfig
from helixd.config.root import HelixdConfig
from helixd.config.safety import StartupConfig


def _models_in(annotation: object) -> list[type[BaseModel]]:
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return [annotation]
    return [m for arg in typing.get_args(annotation) for m in _models_in(arg)]


def _sections() -> list[type[BaseModel]]:
    """HelixdConfig and every model reachable from its fields."""
    found: list[type[BaseModel]] = []
    todo: list[type[BaseModel]] = [HelixdConfig]
    while todo:
        model = todo.pop()
        if model in found:
            continue
        found.append(model)
        for field in model.model_fields.values():
            todo.extend(_models_in(field.annotation))
    return found


def _leaves(models: list[type[BaseModel]]) -> list[tuple[str, FieldInfo]]:
    """(``Model.field``, its info) of every field that is not itself a section."""
    return [
        (f"{model.__name__}.{name}", field)
        for model in models
        for name, field in model.model_fields.items()
        if not _models_in(field.annotation)  # a nested section is described by its own fields
    ]


def _scalar(annotation: object) -> object:
    """int for ``int | None``; the annotation itself otherwise."""
    if typing.get_origin(annotation) in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(annotation) if a is not type(None)]
        return args[0] if len(args) == 1 else annotation
    return annotation


def undescribed(models: list[type[BaseModel]]) -> list[str]:
    return [name for name, field in _leaves(models) if not (field.description or "").strip()]


def unbounded(models: list[type[BaseModel]]) -> list[str]:
    """The int and float fields without a lower or an upper bound."""
    return [
        name
        for name, field in _leaves(models)
        if _scalar(field.annotation) in (int, float)
        and not (
            any(isinstance(m, Ge | Gt) for m in field.metadata)
            and any(isinstance(m, Le | Lt) for m in field.metadata)
        )
    ]


SECTIONS = _sections()


def test_every_section_is_a_config_section() -> None:
    assert len(SECTIONS) >= 20  # the walk reached the nested sections
    assert [m.__name__ for m in SECTIONS if not issubclass(m, ConfigSection)] == []


def test_every_field_has_a_description_and_every_number_two_bounds() -> None:
    assert len(_leaves(SECTIONS)) > 150  # the walk reached the fields
    assert undescribed(SECTIONS) == []
    assert unbounded(SECTIONS) == []


def test_the_checks_name_a_field_without_docstring_or_upper_bound() -> None:
    class Probe(ConfigSection):
        speed_mps: float = Field(1.0, ge=0.0)
        """described, bounded below only (m/s)"""
        count: int = Field(3, ge=0, le=9)
        name: str | None = Field(None)
        """a name"""

    assert undescribed([Probe]) == ["Probe.count"]
    assert unbounded([Probe]) == ["Probe.speed_mps"]


def test_the_docstring_under_a_field_is_its_description() -> None:
    assert LinkConfig.model_fields["baud"].description == "serial baud when url has none"
    connect = StartupConfig.model_fields["connect_timeout_s"]
    assert connect.description == "wait for the autopilot's first HEARTBEAT (s)"
    assert (connect.default, connect.metadata) == (30.0, [Gt(0.0), Le(600.0)])


def test_a_sections_default_is_its_fields_defaults() -> None:
    # every tunable has a default: the whole config builds from nothing
    assert HelixdConfig().link.own_id_watch_s == 2.2
