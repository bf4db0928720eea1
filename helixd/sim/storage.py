"""The autopilot's parameter storage across restarts of the simulator: SITL keeps its
parameters in ``eeprom.bin`` in its working directory, so a restarted SITL boots with what was
set before (``SCR_ENABLE``, a script's ``HXG_*`` values). With a working directory of its own
(``SimConfig.workdir``, ``helixd sim --state-dir``) the simulator does the same with
:data:`STORAGE_FILE` there: the values set since the defaults (the firmware's and the config's)
and a script's stored values, written whenever a parameter changes. A temporary working
directory (the default) is removed at stop, and with it what was stored.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Mapping
from pathlib import Path

import structlog

from helixd.sim.firmware.param_store import DEFAULT_PARAMS, ParamStore
from helixd.sim.sim_config import SimConfig

log = structlog.get_logger(__name__)

STORAGE_FILE = "helixd-sim-params.json"


def read_storage(workdir: Path) -> dict[str, float]:
    """The stored values ({} when there are none). A file that cannot be read is reported and
    ignored: the autopilot boots with its defaults, as ArduPilot does on a blank storage."""
    path = workdir / STORAGE_FILE
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        return {}
    except (OSError, ValueError) as exc:
        log.warning("sim_storage_unreadable", path=str(path), error=str(exc))
        return {}
    if not isinstance(data, dict):
        log.warning("sim_storage_unreadable", path=str(path), error="not a JSON object")
        return {}
    out: dict[str, float] = {}
    for name, value in data.items():
        if isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value):
            out[str(name)] = float(value)
        else:
            log.warning("sim_storage_value_ignored", path=str(path), name=name, value=value)
    return out


def with_storage(config: SimConfig, stored: Mapping[str, float]) -> SimConfig:
    """``config`` with the stored values over it: the firmware's parameters as values to boot
    with, a script's (unknown to the firmware) as its storage (``guard_params``)."""
    firmware = {k: v for k, v in stored.items() if k in DEFAULT_PARAMS}
    script = {k: v for k, v in stored.items() if k not in DEFAULT_PARAMS}
    return config.model_copy(
        update={
            "params": {**config.params, **firmware},
            "guard_params": {**config.guard_params, **script},
        }
    )


def storage_values(params: ParamStore, defaults: Mapping[str, float]) -> dict[str, float]:
    """What to store: the firmware's parameters that differ from ``defaults`` (the values the
    config boots with) and every value a script's parameters have stored."""
    now = params.as_dict()
    changed = {k: v for k, v in now.items() if k in DEFAULT_PARAMS and defaults.get(k) != v}
    return {**changed, **params.stored()}


def write_storage(workdir: Path, values: Mapping[str, float]) -> None:
    """Write the storage file whole (a temporary file renamed over it: never half-written)."""
    path = workdir / STORAGE_FILE
    tmp = path.with_suffix(".tmp")
    try:
        tmp.write_text(json.dumps(dict(sorted(values.items())), indent=1), encoding="utf-8")
        os.replace(tmp, path)
    except OSError as exc:
        log.warning("sim_storage_unwritable", path=str(path), error=str(exc))


__all__ = ["STORAGE_FILE", "read_storage", "storage_values", "with_storage", "write_storage"]
