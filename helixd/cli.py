"""Command-line interface: ``helixd run | check | sim | status | plot | replay | version``.

Errors the operator can fix (bad file, bad URL, refused preflight) are printed as one clear
message per problem and a non-zero exit code — never a traceback.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated

import typer

from helixd import __version__
from helixd.config import ConfigFileError, HelixdConfig, load_config
from helixd.exitcodes import ExitCode
from helixd.mission import Mission, MissionFrameKind, PlanError, load_mission, resolve_plan
from helixd.recorder import command as recorder_command
from helixd.sim import command as sim_command
from helixd.sim.config import NoiseLevel, Terrain

app = typer.Typer(
    name="helixd",
    help="Fly the Helix-25 screw-propelled rover through waypoint missions over MAVLink.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)

ConfigOpt = Annotated[
    Path | None,
    typer.Option("--config", "-c", help="helixd.yaml (defaults built in when omitted)"),
]
MissionOpt = Annotated[Path, typer.Option("--mission", "-m", help="mission YAML file")]


def fail(problems: list[str], code: ExitCode) -> typer.Exit:
    for line in problems:
        typer.echo(f"error: {line}", err=True)
    return typer.Exit(int(code))


def load_inputs(config: Path | None, mission: Path) -> tuple[HelixdConfig, Mission]:
    """Load config and mission together so the operator sees every problem at once."""
    problems: list[str] = []
    cfg: HelixdConfig | None = None
    try:
        cfg = load_config(config)
    except ConfigFileError as exc:
        problems.extend(exc.problems)
    limits = cfg.mission if cfg is not None else HelixdConfig().mission
    msn = None
    try:
        msn = load_mission(mission, limits)
    except ConfigFileError as exc:
        problems.extend(exc.problems)
    if problems or cfg is None or msn is None:
        raise fail(problems, ExitCode.USAGE)
    return cfg, msn


@app.command()
def version() -> None:
    """Print the helixd version."""
    typer.echo(f"helixd {__version__}")


@app.command()
def check(config: ConfigOpt = None, mission: MissionOpt = Path("mission.yaml")) -> None:
    """Validate the config and a mission, and print the resolved plan."""
    cfg, msn = load_inputs(config, mission)
    if msn.frame is MissionFrameKind.GLOBAL:
        first_lat, first_lon = msn.points()[0]
        origin = (first_lat, first_lon)
        note = " (global: shown relative to waypoint 0; the EKF origin is used in flight)"
    else:
        origin = None
        note = ""
    try:
        plan = resolve_plan(msn, cfg.control, cfg.mission, origin)
    except PlanError as exc:
        raise fail([f"{mission}: {exc}"], ExitCode.USAGE) from None
    axes = (
        "x forward / y left of start" if msn.frame is MissionFrameKind.START else "x east / y north"
    )
    typer.echo(f"config  : {config or '(built-in defaults)'}  OK")
    typer.echo(f"mission : {mission}  OK")
    typer.echo(f"plan    : {plan.name}  mode={plan.mode.value}  frame={plan.frame.value}{note}")
    typer.echo(f"axes    : {axes} (metres)")
    typer.echo(f"{'#':>3} {'x_m':>9} {'y_m':>9} {'tol_m':>6} {'heading_deg':>11}")
    for i, wp in enumerate(plan.waypoints):
        hdg = "-" if wp.final_yaw_rad is None else f"{math.degrees(wp.final_yaw_rad):.1f}"
        typer.echo(f"{i:>3} {wp.x_m:>9.2f} {wp.y_m:>9.2f} {wp.tolerance_m:>6.2f} {hdg:>11}")
    start = (0.0, 0.0) if msn.frame is not MissionFrameKind.GLOBAL else None
    length = plan.path_length_m(start or (plan.waypoints[0].x_m, plan.waypoints[0].y_m))
    eta = plan.estimated_time_s(
        cfg.control.max_yaw_rate_radps, start or (plan.waypoints[0].x_m, plan.waypoints[0].y_m)
    )
    typer.echo(f"path    : {length:.1f} m at {plan.speed_mps:.2f} m/s")
    typer.echo(f"estimate: {eta:.0f} s ({eta / 60:.1f} min)")


@app.command()
def run(
    mission: MissionOpt = Path("mission.yaml"),
    config: ConfigOpt = None,
    connect: Annotated[
        str | None,
        typer.Option(
            "--connect",
            help="autopilot link: /dev/ttyACM0[:baud], udpin:HOST:PORT, udpout:HOST:PORT, "
            "tcp:HOST:PORT (default: link.url from the config)",
        ),
    ] = None,
    sim: Annotated[
        bool, typer.Option("--sim", help="fly against the built-in simulator, started in-process")
    ] = False,
    sim_speedup: Annotated[
        float, typer.Option(min=0.1, max=20.0, help="simulator speed-up factor (with --sim)")
    ] = 1.0,
    sim_terrain: Annotated[
        Terrain, typer.Option(help="simulator terrain (with --sim)")
    ] = Terrain.HARD,
    sim_noise: Annotated[
        NoiseLevel, typer.Option(help="simulator pose noise (with --sim)")
    ] = NoiseLevel.LOW,
    run_dir: Annotated[
        Path | None,
        typer.Option("--run-dir", help="root for run directories (default: recorder.run_root)"),
    ] = None,
    log_level: Annotated[str, typer.Option(help="debug, info, warning or error")] = "info",
) -> None:
    """Fly a mission: connect, preflight, arm, fly, and always stop + release + HOLD."""
    import asyncio
    import sys

    from helixd.daemon import RunOptions, run_mission
    from helixd.logging_setup import configure_logging

    cfg, msn = load_inputs(config, mission)
    tty = sys.stderr.isatty()
    configure_logging(tty=tty, level=log_level)
    server = None
    url = connect or cfg.link.url
    if sim:
        if connect:
            raise fail(["--sim and --connect exclude each other"], ExitCode.USAGE)
        from helixd.sim import SimConfig, start_embedded

        sim_cfg = SimConfig(speedup=sim_speedup, terrain=sim_terrain, noise=sim_noise)
        server, url = start_embedded(sim_cfg)
    cfg = cfg.model_copy(update={"link": cfg.link.model_copy(update={"url": url})})
    opts = RunOptions(
        cfg=cfg,
        mission=msn,
        mission_yaml=mission.read_text(encoding="utf-8"),
        connect_url=url,
        run_root=run_dir or cfg.recorder.run_root,
        tty=tty,
    )
    try:
        outcome = asyncio.run(run_mission(opts))
    finally:
        if server is not None:
            server.stop()
    for line in outcome.messages:
        typer.echo(line, err=True)
    if outcome.run_dir is not None:
        typer.echo(f"run directory: {outcome.run_dir}", err=True)
    raise typer.Exit(int(outcome.exit_code))


@app.command()
def status(
    connect: Annotated[
        str | None, typer.Option("--connect", help="autopilot link (default: link.url)")
    ] = None,
    config: ConfigOpt = None,
    watch: Annotated[bool, typer.Option("--watch", help="refresh until Ctrl-C")] = False,
    interval_s: Annotated[float, typer.Option(min=0.2, max=60.0, help="refresh period (s)")] = 1.0,
) -> None:
    """Print mode, armed, pose, EKF health, RC inputs and servo outputs (read-only)."""
    import asyncio
    import sys

    from helixd.link.connection import LinkError
    from helixd.logging_setup import configure_logging
    from helixd.status import read_status

    try:
        cfg = load_config(config)
    except ConfigFileError as exc:
        raise fail(exc.problems, ExitCode.USAGE) from None
    configure_logging(tty=sys.stderr.isatty(), level="warning")
    link = cfg.link if connect is None else cfg.link.model_copy(update={"url": connect})
    try:
        code = asyncio.run(read_status(link, cfg.safety, watch, interval_s, typer.echo))
    except LinkError as exc:
        raise fail([str(exc)], ExitCode.LINK) from None
    except KeyboardInterrupt:
        code = 0
    raise typer.Exit(code)


sim_command.register(app)
recorder_command.register(app)


def main() -> None:
    app()


if __name__ == "__main__":
    main()
