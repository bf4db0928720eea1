"""What the config sections share: their base class, validators and field types."""

from __future__ import annotations

import math
from typing import Annotated

from pydantic import ConfigDict, Field

from helixd.base.polygon import polygon_problems
from helixd.files.models import InputModel


class ConfigSection(InputModel):
    """A section of ``helixd.yaml`` (strict like every input model: unknown keys are errors).

    Each field is written ``name_unit: type = Field(default, bounds)`` with its description in
    the docstring under it, which pydantic reads as the field's description
    (``use_attribute_docstrings``): the unit, the bound, the default and the meaning stand
    together, one field after the other. tests/test_config.py holds every field to it.
    """

    model_config = ConfigDict(use_attribute_docstrings=True)


RcChannel = Annotated[int, Field(ge=1, le=18)]


def distinct_channels(channels: tuple[int, ...]) -> tuple[int, ...]:
    if len(set(channels)) != len(channels):
        raise ValueError(f"each channel may be listed once, got {list(channels)}")
    return channels


def sane_polygon(poly: tuple[tuple[float, float], ...]) -> tuple[tuple[float, float], ...]:
    if not poly:
        return poly
    problems = polygon_problems(poly)
    if problems:
        raise ValueError(
            "\n".join(
                f"{p} (allowed: [] for no polygon, or >= 3 vertices enclosing an area)"
                for p in problems
            )
        )
    return poly


def finite_ne_point(value: tuple[float, float]) -> tuple[float, float]:
    if not all(math.isfinite(v) and abs(v) <= 100_000.0 for v in value):
        raise ValueError("allowed: two finite numbers within ±100000 m")
    return value
