"""helixd-guard's script (package data) and parameters (helixd/mav/guard_script.py), and their
agreement with the Lua."""

from __future__ import annotations

import re

import pytest

from helixd.mav import guard_script as mg
from tests.support.paths import REPO_ROOT

LUA = REPO_ROOT / "helixd" / "mav" / "scripts" / "helixd-guard.lua"


def lua_source() -> str:
    return LUA.read_text(encoding="utf-8")


# --- the packaged script -------------------------------------------------------------------


def test_script_is_package_data_and_declares_its_version() -> None:
    data = mg.script_bytes()
    assert data == LUA.read_bytes()
    assert data.startswith(b"--[[\nhelixd-guard.lua")
    assert mg.script_version(data) == mg.VERSION


def test_packaged_for_an_installed_helixd() -> None:
    """setuptools ships helixd/mav/scripts/*.lua (an installed helixd has no repository)."""
    pyproject = (REPO_ROOT / "pyproject.toml").read_text(encoding="utf-8")
    assert re.search(r'^"helixd\.mav" = \["scripts/\*\.lua"\]$', pyproject, re.MULTILINE)


@pytest.mark.parametrize(
    ("source", "version"),
    [
        (b"local VERSION = 7\n", 7),
        (b"-- x\nlocal VERSION = 12 -- the guard\nlocal Y = 3\n", 12),
        (b"local VERSION=1\n", None),  # not the script's spelling
        (b"print('hello')\n", None),
        (b"", None),
    ],
)
def test_script_version(source: bytes, version: int | None) -> None:
    assert mg.script_version(source) == version


def test_scripts_dirs() -> None:
    # SCRIPTING_DIRECTORY: /APM/scripts with FATFS (SD card), ./scripts otherwise; SITL strips a
    # leading '/' from FTP paths, so the relative name reaches ./scripts there
    assert mg.BOARD_SCRIPTS_DIR == "/APM/scripts"
    assert mg.POSIX_SCRIPTS_DIR == "scripts"


# --- parameters ----------------------------------------------------------------------------


def test_defaults() -> None:
    p = mg.GuardParams()
    assert p.enabled
    assert p.timeout_ms == 500
    assert p.outputs == (1, 2, 3, 4)
    assert mg.PARAM_DEFAULTS["HXG_VERSION"] == mg.VERSION == 1


@pytest.mark.parametrize(
    ("chans", "outputs"),
    [
        ((3, 4, 1, 2), (3, 4, 1, 2)),  # order kept (the SITL skid mapping)
        ((3, 0, 3, 0), (3,)),  # 0 = none, duplicates once
        ((17, -1, 16, 0), (16,)),  # outside 1..16 ignored
        ((2.6, 2.4, 0.4, 0.5), (3, 2, 1)),  # Lua's floor(x + 0.5)
        ((0, 0, 0, 0), ()),
    ],
)
def test_outputs_parsing(
    chans: tuple[float, float, float, float], outputs: tuple[int, ...]
) -> None:
    p = mg.GuardParams(chan1=chans[0], chan2=chans[1], chan3=chans[2], chan4=chans[3])
    assert p.outputs == outputs


@pytest.mark.parametrize(
    ("timeout_s", "ms"), [(0.5, 500), (0.25, 250), (0.0, 100), (0.01, 100), (60.0, 10_000)]
)
def test_timeout_clamped(timeout_s: float, ms: int) -> None:
    assert mg.GuardParams(timeout_s=timeout_s).timeout_ms == ms


def test_from_params_partial_and_nonfinite_rejected() -> None:
    p = mg.GuardParams.from_params({"HXG_TIMEOUT": 0.3, "HXG_CHAN2": 0.0, "OTHER": 9.0})
    assert p.timeout_ms == 300
    assert p.outputs == (1, 3, 4)
    assert p.enabled
    with pytest.raises(ValueError, match="timeout_s"):
        mg.GuardParams(timeout_s=float("nan"))
    with pytest.raises(ValueError, match="chan3"):
        mg.GuardParams.from_params({"HXG_CHAN3": float("inf")})


# --- the Lua says the same ------------------------------------------------------------------


def test_lua_params_match() -> None:
    src = lua_source()
    params = {
        f"HXG_{name}": (int(idx), float(default))
        for name, idx, default in re.findall(r'bind_add_param\("(\w+)",\s*(\d+),\s*([\d.]+)\)', src)
    }
    params["HXG_VERSION"] = (7, mg.VERSION)  # bound with the VERSION constant
    assert list(params) == list(mg.PARAM_DEFAULTS)
    assert [i for i, _ in params.values()] == list(range(1, 8))
    assert {k: v for k, (_, v) in params.items()} == mg.PARAM_DEFAULTS
    assert re.search(r'bind_add_param\("VERSION",\s*7,\s*VERSION\)', src)
    assert re.search(
        rf"param:add_table\(PARAM_TABLE_KEY, PARAM_TABLE_PREFIX, {len(mg.PARAM_DEFAULTS)}\)", src
    )


@pytest.mark.parametrize(
    ("lua_name", "value"),
    [
        ("VERSION", mg.VERSION),
        ("PARAM_TABLE_KEY", mg.PARAM_TABLE_KEY),
        ("MAX_OUTPUT", mg.MAX_OUTPUT),
        ("TIMEOUT_MIN_MS", mg.TIMEOUT_MIN_MS),
        ("TIMEOUT_MAX_MS", mg.TIMEOUT_MAX_MS),
    ],
)
def test_lua_constants_match(lua_name: str, value: int) -> None:
    m = re.search(rf"^local {lua_name} = (\d+)", lua_source(), re.MULTILINE)
    assert m is not None, lua_name
    assert int(m.group(1)) == value
    assert f'PARAM_TABLE_PREFIX = "{mg.PARAM_PREFIX}"' in lua_source()
