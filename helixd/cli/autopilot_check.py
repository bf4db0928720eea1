"""``helixd autopilot check``: is the autopilot set up so that the Helix arms honestly — a
normal arm, every PreArm check made — and obeys helixd?
(:mod:`helixd.link.services.autopilot_setup`)

Registered on the ``autopilot`` group by :func:`register` (in :mod:`helixd.cli.app`).
Prints one line per topic (``ok`` / ``warning`` / ``error``, what to set). Exit codes: 0 all
good (warnings allowed); 2 bad command line or config; 3 something to change (PREFLIGHT);
6 no link or no answers.
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import Iterator
from typing import Annotated

import typer

from helixd.base.exitcodes import ExitCode
from helixd.cli.common import ConfigOpt, ObserverConnectOpt, fail, link_inputs, run_on_link
from helixd.cli.simulated import embedded_guard
from helixd.config.root import HelixdConfig
from helixd.link.connection import Autopilot
from helixd.link.services.autopilot_setup import SetupLine, failed, judge_setup, read_setup
from helixd.link.services.command_client import CommandError
from helixd.link.vehicle import Change
from helixd.mav.constants import MAV_CMD_REQUEST_MESSAGE, MAVLINK_MSG_ID_RC_CHANNELS
from helixd.sim.server import start_embedded
from helixd.sim.sim_config import SimConfig

SIM_BOOT_WAIT_S = 30.0
SimOpt = Annotated[
    bool,
    typer.Option(
        "--sim",
        help="check the built-in simulator (set up as the README asks a real Helix to be)",
    ),
]


@contextlib.contextmanager
def _target(cfg: HelixdConfig, url: str, sim: bool) -> Iterator[str]:
    if not sim:
        yield url
        return
    sim_cfg = SimConfig(guard_installed=True, guard_params=embedded_guard(cfg, 1.0))
    server, sim_url = start_embedded(sim_cfg)
    try:
        # its scripts (helixd-guard and its HXG_* parameters) start when the boot ends
        server.wait_for(lambda s: not s.booting and not s.silent, SIM_BOOT_WAIT_S)
        yield sim_url
    finally:
        server.stop()


def report(url: str, lines: list[SetupLine]) -> list[str]:
    """What the operator reads (pure): every line, then the verdict."""
    out = [str(line) for line in lines]
    if failed(lines):
        out.append(f"{url}: not ready — change the parameters above (then reboot the autopilot)")
    else:
        out.append(f"{url}: a normal arm is possible (no force) and the autopilot obeys helixd")
    return out


async def rc_inputs(ap: Autopilot, timeout_s: float) -> tuple[int, ...]:
    """The pilot's RC inputs (RC_CHANNELS, µs), asked for once (an observer asks for no
    streams); empty when none came within ``timeout_s`` (no receiver: ArduPilot then does not
    check the throttle channel at arming either)."""
    if ap.state.rc_rx_s is None:
        with contextlib.suppress(CommandError):
            await ap.action.command_long(MAV_CMD_REQUEST_MESSAGE, (MAVLINK_MSG_ID_RC_CHANNELS,))
        await ap.telemetry.wait_for(lambda st: st.rc_rx_s is not None, Change.RC, timeout_s)
    return ap.state.rc_inputs_us


async def setup_lines(ap: Autopilot, cfg: HelixdConfig) -> list[SetupLine]:
    """The check's lines: the parameters read and the pilot's RC inputs, judged."""
    params, rc_inputs_us = await asyncio.gather(
        read_setup(ap, cfg.actuation), rc_inputs(ap, cfg.link.command_timeout_s)
    )
    return judge_setup(params, cfg.actuation, cfg.link, cfg.safety.servo_guard, rc_inputs_us)


def check_command(
    connect: ObserverConnectOpt = None, config: ConfigOpt = None, sim: SimOpt = False
) -> None:
    """Check the autopilot's setup for helixd: a normal arm passes the motor-output check (a
    spare output with SERVOn_FUNCTION = 94), no PreArm check is skipped, the scroll outputs
    suit the backend, helixd's system id is the GCS id."""
    if sim and connect is not None:
        raise fail(["--sim and --connect exclude each other"], ExitCode.USAGE)
    cfg, link = link_inputs(config, connect)

    async def body(ap: Autopilot) -> list[SetupLine]:
        return await setup_lines(ap, cfg)

    with _target(cfg, link.url, sim) as url:
        target = link.model_copy(update={"url": url})
        lines = run_on_link(cfg, target, body)
    for line in report(url, lines):
        typer.echo(line)
    if failed(lines):
        raise typer.Exit(int(ExitCode.PREFLIGHT))


def register(app: typer.Typer) -> None:
    app.command("check")(check_command)
