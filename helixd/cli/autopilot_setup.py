"""``helixd autopilot setup``: load a parameter file onto the autopilot (for a Helix:
config/ardupilot/helix.parm): show what would change, ask, set, say whether a reboot is
needed (``--reboot``: reboot it, disarmed only, as ``install-guard --reboot`` does), then run
``helixd autopilot check``.

Refused while the autopilot is armed. Exit codes: 0 set (or nothing to change) and the check
passes; 2 bad command line, config or parameter file; 3 the check still finds something to
change, or the autopilot refused a value; 5 the operator said no (nothing set); 6 no link or no
answers.
"""

from __future__ import annotations

import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Annotated

import typer

from helixd.base.exitcodes import ExitCode
from helixd.cli.autopilot_check import report, setup_lines
from helixd.cli.common import ConfigOpt, ObserverConnectOpt, fail, link_inputs, run_on_link
from helixd.cli.guard import REBOOT_AUTOPILOT, RebootRefused, reboot_line
from helixd.files.parmfile import ParmFileError, load_parm
from helixd.link.connection import Autopilot
from helixd.link.services.autopilot_setup import SetupLine, failed
from helixd.link.services.command_client import CommandError
from helixd.link.services.param_plan import ParamChange, plan_changes, reboot_needed, same_value
from helixd.mav.constants import MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN

FileOpt = Annotated[
    list[Path],
    typer.Option(
        "--file",
        "-f",
        metavar="<path>",
        help="parameter file (NAME VALUE lines; repeatable, later files win), e.g. "
        "config/ardupilot/helix.parm, then helix-servo.parm for the servo backend",
    ),
]
YesOpt = Annotated[bool, typer.Option("--yes", "-y", help="set without asking")]
SetupRebootOpt = Annotated[
    bool,
    typer.Option(
        "--reboot",
        help="then reboot the autopilot when a parameter set takes effect only at boot "
        "(disarmed only); sends MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN (246) param1=1",
    ),
]


class ArmedError(RuntimeError):
    pass


def _wanted(files: list[Path]) -> dict[str, float]:
    wanted: dict[str, float] = {}
    problems: list[str] = []
    for path in files:
        try:
            wanted.update(load_parm(path))
        except ParmFileError as exc:
            problems += exc.problems
    if problems:
        raise fail(problems, ExitCode.USAGE)
    if not wanted:
        raise fail([f"{', '.join(map(str, files))}: no parameters in it"], ExitCode.USAGE)
    return wanted


def _refuse_armed(ap: Autopilot) -> None:
    if ap.state.armed:
        raise ArmedError("the autopilot is armed: disarm before changing its parameters")


def setup_command(
    file: FileOpt,
    connect: ObserverConnectOpt = None,
    config: ConfigOpt = None,
    yes: YesOpt = False,
    reboot: SetupRebootOpt = False,
) -> None:
    """Load a parameter file onto the autopilot: show the difference, ask, set, check the
    setup (as `helixd autopilot check`), then say whether to reboot (--reboot: reboot it)."""
    wanted = _wanted(file)
    cfg, link = link_inputs(config, connect)

    async def read(ap: Autopilot) -> Mapping[str, float | None]:
        _refuse_armed(ap)
        return {name: await ap.param.get(name) for name in wanted}

    try:
        current = run_on_link(cfg, link, read)
    except ArmedError as exc:
        raise fail([f"{link.url}: {exc}"], ExitCode.PREFLIGHT) from None
    changes, missing = plan_changes(wanted, current)
    for name in missing:
        typer.echo(f"skip    {name}: the autopilot has no such parameter (other firmware?)")
    if not changes:
        typer.echo(f"{link.url}: every parameter already has the file's value")
    else:
        typer.echo(f"{len(changes)} parameters to set:")
        for change in changes:
            typer.echo(f"  {change.line()}")
        if not yes:
            if not sys.stdin.isatty():
                raise fail(["not asked (no terminal): run it again with --yes to set them"])
            if not typer.confirm("Set them?", default=False):
                typer.echo("nothing set")
                raise typer.Exit(int(ExitCode.OPERATOR_STOP))

    at_boot = reboot_needed(c.name for c in changes)

    async def apply(ap: Autopilot) -> tuple[list[str], list[SetupLine]]:
        _refuse_armed(ap)
        refused = await _set_all(ap, changes)
        lines = await setup_lines(ap, cfg)
        if reboot and at_boot:
            await _reboot(ap, cfg.link.target_system, cfg.link.target_component)
        return refused, lines

    try:
        refused, lines = run_on_link(cfg, link, apply)
    except (ArmedError, RebootRefused) as exc:
        raise fail([f"{link.url}: {exc}"], ExitCode.PREFLIGHT) from None
    _tell_reboot(changes, refused, rebooted=reboot)
    for line in report(link.url, lines):
        typer.echo(line)
    for text in refused:
        typer.echo(f"error   {text}")
    if refused or failed(lines):
        raise typer.Exit(int(ExitCode.PREFLIGHT))


async def _set_all(ap: Autopilot, changes: list[ParamChange]) -> list[str]:
    """Set each; the ones the autopilot did not take, in words."""
    refused: list[str] = []
    for change in changes:
        got = await ap.param.set(change.name, change.wanted)
        if not same_value(got, change.wanted):
            refused.append(f"{change.name}: the autopilot kept {got:g}, not {change.wanted:g}")
    return refused


async def _reboot(ap: Autopilot, target_system: int, target_component: int) -> None:
    """Ask the autopilot to reboot (after the check: its answers end with the reboot)."""
    if ap.state.armed:
        raise RebootRefused("the autopilot armed during the setup: set, but not rebooted")
    typer.echo(reboot_line(target_system, target_component))
    try:
        await ap.action.command_long(MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, (REBOOT_AUTOPILOT,))
    except CommandError as exc:
        raise RebootRefused(f"set, but the reboot was refused: {exc}") from None


def _tell_reboot(changes: list[ParamChange], refused: list[str], rebooted: bool = False) -> None:
    if not changes:
        return
    typer.echo(f"set {len(changes) - len(refused)} of {len(changes)}")
    later = reboot_needed(c.name for c in changes)
    if later and rebooted:
        typer.echo(f"the autopilot accepted the reboot: {', '.join(later)} take effect as it boots")
    elif later:
        typer.echo(
            f"reboot the autopilot: {', '.join(later)} take effect at boot (or run this again "
            "with --reboot)"
        )
    else:
        typer.echo("no reboot needed")


def register(app: typer.Typer) -> None:
    app.command("setup")(setup_command)
