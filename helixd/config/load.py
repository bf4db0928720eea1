"""Which config file a command reads, loading it, and writing it back as YAML."""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path

import yaml
from pydantic import BaseModel

from helixd.config.root import HelixdConfig
from helixd.files.models import ConfigFileError, load_yaml_model
from helixd.mav.signing_key import SigningKeyError, parse_signing_key

CONFIG_ENV = "HELIXD_CONFIG"  # the config file when no -c is given; set empty: built-in defaults
ROVER_CONFIG_PATH = Path("/etc/helixd/helixd.yaml")  # tools/install.sh writes it on the rover


def default_config_path(environ: Mapping[str, str] | None = None) -> Path | None:
    """The config a command reads when not given one (``-c``): ``$HELIXD_CONFIG`` when set
    (empty: the built-in defaults), else :data:`ROVER_CONFIG_PATH` when it exists (the rover),
    else None (the built-in defaults)."""
    env = os.environ if environ is None else environ
    named = env.get(CONFIG_ENV)
    if named is not None:
        return Path(named) if named.strip() else None
    return ROVER_CONFIG_PATH if ROVER_CONFIG_PATH.is_file() else None


def config_label(path: Path | str | None) -> str:
    """How a command names the config it read."""
    return "built-in defaults" if path is None else str(path)


def load_config(path: Path | str | None) -> HelixdConfig:
    """Load ``path`` (or the built-in defaults when None), and the files it names: what
    ``run`` would refuse on opening them, ``check`` refuses too (ConfigFileError, one line
    each)."""
    if path is None:
        return HelixdConfig()
    cfg = load_yaml_model(path, HelixdConfig)
    problems = named_file_problems(cfg, path)
    if problems:
        raise ConfigFileError(path, problems)
    return cfg


def named_file_problems(cfg: HelixdConfig, source: Path | str) -> list[str]:
    """Files the config names that ``run`` reads: ``link.signing_key_file`` must be a readable
    MAVLink signing key (the link reads it again when it opens)."""
    key = cfg.link.signing_key_file
    if key is None:
        return []
    where = f"{source}: link.signing_key_file"
    try:
        data = key.read_bytes()
    except OSError as exc:
        return [f"{where}: cannot read {key} ({exc.strerror or exc})"]
    try:
        parse_signing_key(data)
    except SigningKeyError as exc:
        return [f"{where}: {key}: {exc}"]
    return []


def config_to_yaml(cfg: BaseModel) -> str:
    """The resolved config as YAML (Paths and enums as plain strings)."""
    return yaml.safe_dump(cfg.model_dump(mode="json"), sort_keys=False)
