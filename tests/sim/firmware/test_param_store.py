"""The simulator starts set up for helixd (the README's recommended setup)."""

from __future__ import annotations

import pytest
from pydantic import ValidationError

from helixd.config.link import LinkConfig
from helixd.sim.firmware.param_store import DEFAULT_PARAMS, ParamStore, ParamType
from helixd.sim.sim_config import HELIXD_SYSID, SimConfig
from tests.support.paths import REPO_ROOT


def test_defaults_are_helixd_s_recommended_setup() -> None:
    params = SimConfig().params
    assert HELIXD_SYSID == LinkConfig().source_system != 255
    assert params["MAV_GCS_SYSID"] == HELIXD_SYSID
    assert params["FS_GCS_ENABLE"] == 1.0
    assert params["FS_ACTION"] == 2.0  # HOLD
    # ArduPilot's own defaults stay in the parameter table, for tests that ask for them
    assert DEFAULT_PARAMS["MAV_GCS_SYSID"].default == 255
    assert DEFAULT_PARAMS["FS_GCS_ENABLE"].default == 0


def test_given_params_are_merged_over_the_setup() -> None:
    cfg = SimConfig(params={"RC_OVERRIDE_TIME": 2.0})
    assert cfg.params["RC_OVERRIDE_TIME"] == 2.0
    assert cfg.params["MAV_GCS_SYSID"] == HELIXD_SYSID
    raw = SimConfig(params={"MAV_GCS_SYSID": 255.0, "FS_GCS_ENABLE": 0.0})
    assert raw.params["MAV_GCS_SYSID"] == 255.0 and raw.params["FS_GCS_ENABLE"] == 0.0
    again = SimConfig.model_validate(raw.model_dump())
    assert again.params == raw.params


def test_the_real_sitl_parameter_file_matches_helixd_s_id() -> None:
    parm = REPO_ROOT / "tests" / "sitl" / "helix-skid.parm"
    values = dict(
        line.split()[:2] for line in parm.read_text().splitlines() if line and line[0] != "#"
    )
    assert float(values["MAV_GCS_SYSID"]) == HELIXD_SYSID
    assert values["FS_GCS_ENABLE"] == "1"


def test_script_params_appear_when_added_and_keep_their_stored_values() -> None:
    store = ParamStore(stored={"HXG_TIMEOUT": 0.3})
    n = len(store)
    assert "HXG_TIMEOUT" not in store
    assert store.add_script_param("HXG_TIMEOUT", 0.5) == 0.3  # from storage
    assert store.add_script_param("HXG_ENABLE", 1.0) == 1.0  # the script's default
    assert len(store) == n + 2 and store.name_at(n) == "HXG_TIMEOUT"
    assert store.kind("HXG_ENABLE") is ParamType.REAL32
    store.set("HXG_ENABLE", 0.0)
    assert store.add_script_param("HXG_ENABLE", 1.0) == 0.0  # adding again keeps the value
    store.on_reboot()
    assert "HXG_ENABLE" not in store and len(store) == n
    assert store.add_script_param("HXG_ENABLE", 1.0) == 0.0  # the set value was stored


def test_guard_settings_are_checked() -> None:
    assert SimConfig(guard_params={"HXG_TIMEOUT": 2.0}).guard_params == {"HXG_TIMEOUT": 2.0}
    with pytest.raises(ValidationError, match="HXG_VERSION"):
        SimConfig(guard_params={"HXG_VERSION": 2.0})
    with pytest.raises(ValidationError, match="HXG_TIMOUT"):
        SimConfig(guard_params={"HXG_TIMOUT": 2.0})
    assert SimConfig().guard_installed is False and SimConfig().workdir is None
