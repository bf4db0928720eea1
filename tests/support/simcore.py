"""Driving the simulator core without sockets: build it, tick it, send it messages."""

from __future__ import annotations

import os
from typing import Any

import numpy as np
import pytest

os.environ.setdefault("MAVLINK20", "1")
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.plant.collisions import SimObstacles, constrain, distance_m
from helixd.plant.state import PhysicsState
from helixd.sim.core import FtpHandler, SimCore
from helixd.sim.firmware.rover_firmware import SimEvent
from helixd.sim.sim_config import HELIXD_SYSID, SimConfig


def make_core(n_links: int = 2, ftp: FtpHandler | None = None, **cfg: Any) -> SimCore:
    config = SimConfig.model_validate(
        {"noise": "none", "boot_duration_s": 1.0, "ekf_origin_delay_s": 0.5, **cfg}
    )
    return SimCore(config, n_links, np.random.default_rng(1), ftp=ftp)


def run(core: SimCore, seconds: float) -> list[tuple[int | None, Any]]:
    out: list[tuple[int | None, Any]] = []
    for _ in range(round(seconds / core.dt_s())):
        core.tick()
        out.extend(core.drain_outbox())
    return out


def skid_north_contacts(core: SimCore, seconds: float) -> list[SimEvent]:
    """Boot the skid-plant ``core`` (2 s), then both motors forward, straight north from
    (0, 0), for ``seconds``: the contact events of the drive."""
    run(core, 2.0)
    core.drain_events()
    core.set_rc(1, 1700)  # RCIN1 → output 1, the left motor
    core.set_rc(3, 1700)  # RCIN3 → output 3, the right motor
    run(core, seconds)
    return [e for e in core.drain_events() if e.kind == "contact"]


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


def assert_step_never_closer(obs: SimObstacles, n: float, e: float, dn: float, de: float) -> None:
    """One physics step from (n, e) by (dn, de) through :func:`constrain`: a contact never ends
    closer to the obstacles than it started (or than the contact radius); a free step is
    left as it was and stays outside the contact radius."""
    before = PhysicsState(north_m=n, east_m=e)
    after = PhysicsState(north_m=n + dn, east_m=e + de, vx_body_mps=0.3)
    state, contact = constrain(obs, before, after)
    d0, d1 = distance_m(obs, n, e), distance_m(obs, state.north_m, state.east_m)
    if contact:
        assert d1 >= d0 or d1 >= obs.contact_radius_m
    else:
        assert d1 >= obs.contact_radius_m and state == after


class EmbeddedStart(Exception):
    """Raised by the stand-in for the simulator's start: the CLI got that far."""


def capture_embedded_start(monkeypatch: pytest.MonkeyPatch) -> list[SimConfig]:
    """Replace the embedded simulator's start (as :mod:`helixd.cli.simulated` calls it) by a
    stand-in that records the configuration it is given and raises :class:`EmbeddedStart`;
    the list fills as the CLI calls it."""
    import helixd.cli.simulated

    seen: list[SimConfig] = []

    def start(cfg: SimConfig, extra_links: tuple[str, ...] = (), judge_pace: bool = False) -> Any:
        assert judge_pace  # the CLI's wall-clock simulator says when it cannot keep the pace
        seen.append(cfg)
        raise EmbeddedStart

    monkeypatch.setattr(helixd.cli.simulated, "start_embedded", start)
    return seen
