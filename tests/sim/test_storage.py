"""helixd.sim.storage: the parameters a restarted simulator boots with (SITL's eeprom.bin)."""

from __future__ import annotations

from pathlib import Path

from helixd.sim.firmware.param_store import ParamStore
from helixd.sim.sim_config import SimConfig
from helixd.sim.storage import (
    STORAGE_FILE,
    read_storage,
    storage_values,
    with_storage,
    write_storage,
)


def test_what_was_set_is_stored_and_boots_again(tmp_path: Path) -> None:
    config = SimConfig()
    defaults = ParamStore(dict(config.params)).as_dict()
    params = ParamStore(dict(config.params), stored={})
    params.set("SCR_ENABLE", 1)
    params.add_script_param("HXG_TIMEOUT", 1.5)
    params.set("HXG_TIMEOUT", 0.8)
    values = storage_values(params, defaults)
    assert values == {"SCR_ENABLE": 1.0, "HXG_TIMEOUT": 0.8}  # only what differs, and HXG_*
    write_storage(tmp_path, values)
    booted = with_storage(config, read_storage(tmp_path))
    again = ParamStore(dict(booted.params), stored=booted.guard_params)
    assert again.get("SCR_ENABLE") == 1.0
    assert again.add_script_param("HXG_TIMEOUT", 1.5) == 0.8


def test_a_damaged_storage_boots_with_the_defaults(tmp_path: Path) -> None:
    (tmp_path / STORAGE_FILE).write_text("{not json", encoding="utf-8")
    assert read_storage(tmp_path) == {}
    (tmp_path / STORAGE_FILE).write_text('{"SCR_ENABLE": "yes", "FS_GCS_ENABLE": 0}')
    assert read_storage(tmp_path) == {"FS_GCS_ENABLE": 0.0}
    assert read_storage(tmp_path / "none") == {}
