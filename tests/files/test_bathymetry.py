"""Bathymetry files read as hostile input (helixd/files/bathymetry.py)."""

from __future__ import annotations

from pathlib import Path

import pytest

from helixd.files.bathymetry import read_bathymetry
from helixd.files.models import ConfigFileError

ROOT = Path(__file__).resolve().parents[2]
HEAD = "format: helixd-bathymetry/1\nsouth_west: {lat_deg: 53.5, lon_deg: -113.5}\ncell_m: 1.0\n"


def _file(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "bottom.yaml"
    path.write_text(text)
    return path


def test_the_shipped_bathymetries_read() -> None:
    for name in ("pond-bathymetry.yaml", "pond-bathymetry-channel.yaml"):
        bathy = read_bathymetry(ROOT / "config" / "maps" / name)
        assert bathy.shape == (45, 35)
        depths = [d for row in bathy.depth_m for d in row if d is not None]
        assert min(depths) >= 0.3 and max(depths) <= 4.0


def test_a_small_grid_with_dry_nodes_reads(tmp_path: Path) -> None:
    bathy = read_bathymetry(_file(tmp_path, HEAD + "depth_m:\n- [null, 0.5]\n- [1.0, 2.0]\n"))
    assert bathy.shape == (2, 2) and bathy.depth_m[0][0] is None


@pytest.mark.parametrize(
    ("body", "says"),
    [
        ("depth_m:\n- [1.0, 2.0]\n- [1.0]\n", "row 1 has 1 nodes"),
        ("depth_m:\n- [1.0, .nan]\n- [1.0, 1.0]\n", "depth_m.0.1"),
        ("depth_m:\n- [1.0, .inf]\n- [1.0, 1.0]\n", "depth_m.0.1"),
        ("depth_m:\n- [1.0, -0.5]\n- [1.0, 1.0]\n", "[0][1]"),
        ("depth_m:\n- [null, null]\n- [null, null]\n", "every node is null"),
        ("depth_m:\n- [1.0, 1.0]\n", "at least 2"),
        ("depth_m:\n- [1.0, 1.0]\n- [1.0, 1.0]\nextra: 1\n", "extra"),
        ("depth_m:\n- [1.0, 'deep']\n- [1.0, 1.0]\n", "depth_m"),
    ],
)
def test_bad_grids_are_refused_naming_the_file_and_field(
    tmp_path: Path, body: str, says: str
) -> None:
    with pytest.raises(ConfigFileError) as err:
        read_bathymetry(_file(tmp_path, HEAD + body))
    text = "\n".join(err.value.problems)
    assert "bottom.yaml" in text and says in text


def test_a_wrong_format_or_place_is_refused(tmp_path: Path) -> None:
    grid = "depth_m:\n- [1.0, 1.0]\n- [1.0, 1.0]\n"
    for head in (
        HEAD.replace("helixd-bathymetry/1", "helixd-bathymetry/2"),
        HEAD.replace("53.5", "95.0"),
        HEAD.replace("cell_m: 1.0", "cell_m: 0.0"),
        "south_west: {lat_deg: 53.5, lon_deg: -113.5}\ncell_m: 1.0\n",  # no format
    ):
        with pytest.raises(ConfigFileError):
            read_bathymetry(_file(tmp_path, head + grid))
    with pytest.raises(ConfigFileError):
        read_bathymetry(tmp_path / "none.yaml")
