"""map_server maps as hostile input: every bad file gets one error naming the file and field."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from PIL import Image

from helixd.planning.mapfile import MapFileError, load_map

GOOD = {
    "image": "m.pgm",
    "resolution": 0.5,
    "origin": "[-2.0, -3.0, 0.0]",
    "negate": 0,
    "occupied_thresh": 0.65,
    "free_thresh": 0.196,
    "mode": "trinary",
}


def save_map(
    yaml_path: Path,
    blocked: npt.NDArray[Any],
    resolution_m: float,
    origin_ne_m: tuple[float, float],
) -> None:
    """Write a trinary map_server map (PGM + YAML) from a blocked mask [row north, col east]."""
    pixels = np.where(blocked[::-1], 0, 254).astype(np.uint8)
    image = yaml_path.with_suffix(".pgm")
    Image.fromarray(pixels, mode="L").save(image)
    yaml_path.write_text(
        f"image: {image.name}\nresolution: {resolution_m}\n"
        f"origin: [{origin_ne_m[1]}, {origin_ne_m[0]}, 0.0]\n"
        "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\nmode: trinary\n",
        encoding="utf-8",
    )


def write(tmp: Path, pixels: np.ndarray | None = None, **fields: object) -> Path:
    doc = {**GOOD, **fields}
    if pixels is None:
        pixels = np.full((4, 6), 254, dtype=np.uint8)
    Image.fromarray(pixels, mode="L").save(tmp / "m.pgm")
    text = "".join(f"{k}: {v}\n" for k, v in doc.items() if v is not None)
    (tmp / "map.yaml").write_text(text, encoding="utf-8")
    return tmp / "map.yaml"


def test_map_server_semantics_rows_north_and_thresholds(tmp_path: Path) -> None:
    px = np.full((4, 6), 254, dtype=np.uint8)
    px[0, 0] = 0  # top-left pixel: occupied, northern row
    px[3, 5] = 205  # unknown grey (p = 0.196..0.65): blocked too
    px[3, 4] = 210  # p = 0.176 < free_thresh: free
    m = load_map(write(tmp_path, px), max_cells=1000)
    assert (m.frame.rows, m.frame.cols, m.frame.resolution_m) == (4, 6, 0.5)
    assert (m.frame.origin_north_m, m.frame.origin_east_m) == (-3.0, -2.0)  # y north, x east
    assert m.blocked[3, 0] and m.blocked[0, 5] and not m.blocked[0, 4]
    assert int(m.blocked.sum()) == 2
    negated = load_map(write(tmp_path, px, negate=1), max_cells=1000)
    assert negated.blocked[3, 0] == False  # noqa: E712 - 0 is free when negated
    assert negated.blocked[0, 1]


def test_save_and_load_round_trip(tmp_path: Path) -> None:
    blocked = np.random.default_rng(3).random((7, 9)) < 0.3
    save_map(tmp_path / "rt.yaml", blocked, 0.25, (5.0, -4.0))
    m = load_map(tmp_path / "rt.yaml", max_cells=1000)
    assert (m.blocked == blocked).all()
    assert (m.frame.origin_north_m, m.frame.origin_east_m) == (5.0, -4.0)


@pytest.mark.parametrize(
    ("fields", "message"),
    [
        ({"resolution": ".nan"}, "resolution: nan out of range"),
        ({"resolution": 0}, "resolution: 0 out of range"),
        ({"resolution": "fine"}, "resolution: 'fine' is not a number"),
        ({"resolution": None}, "resolution: missing"),
        ({"origin": "[.nan, 0, 0]"}, "origin[0]: nan out of range"),
        ({"origin": "[0, 1e300, 0]"}, "origin[1]: 1e+300 out of range"),
        ({"origin": "[0, 0]"}, "origin: [0, 0] is not [x, y, yaw]"),
        ({"origin": "[0, 0, 0.5]"}, "origin[2]: yaw 0.5 rad; rotated maps are not supported"),
        ({"image": "missing.pgm"}, "image: 'missing.pgm': no such file"),
        ({"image": "../etc/passwd"}, "image: '../etc/passwd' points outside the map's folder"),
        ({"image": "/etc/passwd"}, "image: '/etc/passwd' points outside the map's folder"),
        ({"image": None}, "image: missing"),
        ({"negate": 2}, "negate: 2 (allowed: 0 or 1)"),
        ({"mode": "fancy"}, "mode: 'fancy' (allowed: trinary, scale, raw)"),
        ({"free_thresh": 0.9}, "free_thresh 0.9 must be < occupied_thresh 0.65"),
        ({"occupied_thresh": 7}, "occupied_thresh: 7 out of range"),
        ({"colour": "red"}, "unknown key(s) ['colour']"),
    ],
)
def test_hostile_yaml_fields_are_named(
    tmp_path: Path, fields: dict[str, object], message: str
) -> None:
    path = write(tmp_path, **fields)
    with pytest.raises(MapFileError) as err:
        load_map(path, max_cells=1000)
    text = str(err.value)
    assert text.startswith(f"{path}: ")
    assert message in text
    assert "\n" not in text


def test_huge_image_is_refused_before_decoding(tmp_path: Path) -> None:
    # a PGM header claiming 5000 × 5000 pixels with no data behind it
    (tmp_path / "m.pgm").write_bytes(b"P5\n5000 5000\n255\n")
    (tmp_path / "map.yaml").write_text("image: m.pgm\nresolution: 0.1\norigin: [0, 0, 0]\n")
    with pytest.raises(MapFileError, match=r"image: 5000 × 5000 pixels; allowed 1\.\.1000 "):
        load_map(tmp_path / "map.yaml", max_cells=1000)
    # beyond Pillow's own bomb limit: refused by Pillow at open, still naming the field
    (tmp_path / "m.pgm").write_bytes(b"P5\n100000 100000\n255\n")
    with pytest.raises(MapFileError, match=r"map\.yaml: image: m\.pgm: cannot read: .*bomb"):
        load_map(tmp_path / "map.yaml", max_cells=1000)


def test_not_an_image_and_wrong_format(tmp_path: Path) -> None:
    (tmp_path / "m.pgm").write_bytes(b"hello")
    (tmp_path / "map.yaml").write_text("image: m.pgm\nresolution: 0.1\norigin: [0, 0, 0]\n")
    with pytest.raises(MapFileError, match=r"image: m\.pgm: cannot read"):
        load_map(tmp_path / "map.yaml", max_cells=1000)
    Image.new("L", (3, 3)).save(tmp_path / "m.bmp")
    (tmp_path / "map.yaml").write_text("image: m.bmp\nresolution: 0.1\norigin: [0, 0, 0]\n")
    with pytest.raises(MapFileError, match=r"image: m\.bmp is BMP, allowed: PGM or PNG"):
        load_map(tmp_path / "map.yaml", max_cells=1000)


def test_yaml_that_is_not_a_mapping_or_not_yaml(tmp_path: Path) -> None:
    (tmp_path / "map.yaml").write_text("- 1\n- 2\n")
    with pytest.raises(MapFileError, match="not a map_server YAML mapping"):
        load_map(tmp_path / "map.yaml", max_cells=1000)
    (tmp_path / "map.yaml").write_text("a: *x\n")
    with pytest.raises(MapFileError, match=str(tmp_path / "map.yaml")):
        load_map(tmp_path / "map.yaml", max_cells=1000)
    with pytest.raises(MapFileError, match="file not found"):
        load_map(tmp_path / "nope.yaml", max_cells=1000)


@settings(
    max_examples=200, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    st.dictionaries(
        st.sampled_from(sorted(GOOD)),
        st.one_of(
            st.floats(allow_nan=True, allow_infinity=True).map(repr),
            st.integers(-(10**30), 10**30).map(str),
            st.text(max_size=20).map(lambda s: repr(s)),
            st.lists(st.floats(allow_nan=True).map(repr), max_size=4).map(
                lambda v: "[" + ", ".join(v) + "]"
            ),
        ),
    )
)
def test_fuzzed_fields_load_or_raise_map_file_error(tmp_path: Path, fields: dict[str, str]) -> None:
    path = write(tmp_path, **fields)
    try:
        m = load_map(path, max_cells=1000)
    except MapFileError as exc:
        assert str(exc).startswith(str(path)) or "m.pgm" in str(exc) or str(tmp_path) in str(exc)
        return
    assert math.isfinite(m.frame.resolution_m) and m.frame.resolution_m > 0
    assert math.isfinite(m.frame.origin_north_m) and math.isfinite(m.frame.origin_east_m)
