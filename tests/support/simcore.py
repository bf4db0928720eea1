"""Driving the simulator core without sockets: build it, tick it, send it messages."""

from __future__ import annotations

import os
from typing import Any

import numpy as np

os.environ.setdefault("MAVLINK20", "1")
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.sim.config import HELIXD_SYSID, SimConfig
from helixd.sim.core import SimCore


def make_core(n_links: int = 2, **cfg: Any) -> SimCore:
    config = SimConfig.model_validate(
        {"noise": "none", "boot_duration_s": 1.0, "ekf_origin_delay_s": 0.5, **cfg}
    )
    return SimCore(config, n_links, np.random.default_rng(1))


def run(core: SimCore, seconds: float) -> list[tuple[int | None, Any]]:
    out: list[tuple[int | None, Any]] = []
    for _ in range(round(seconds / core.dt_s())):
        core.tick()
        out.extend(core.drain_outbox())
    return out


def of_type(out: list[tuple[int | None, Any]], kind: str, link: int | None = None) -> list[Any]:
    return [m for lk, m in out if m.get_type() == kind and (link is None or lk == link)]


def incoming(msg: Any, sysid: int = HELIXD_SYSID, compid: int = 190) -> Any:
    """Stamp a message as if received from (sysid, compid)."""
    mav = mavlink.MAVLink(None, srcSystem=sysid, srcComponent=compid)
    return mav.decode(bytearray(msg.pack(mav)))


def command(core: SimCore, link: int, cmd: int, *p: float, sysid: int = HELIXD_SYSID) -> int:
    params = [float(x) for x in p] + [0.0] * (7 - len(p))
    core.handle(link, incoming(mavlink.MAVLink_command_long_message(1, 1, cmd, 0, *params), sysid))
    acks = [m for _, m in core.drain_outbox() if m.get_type() == "COMMAND_ACK"]
    assert acks, "no COMMAND_ACK"
    return int(acks[-1].result)
