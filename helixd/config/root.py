"""The whole config (:class:`HelixdConfig`) and the rules that relate its sections."""

from __future__ import annotations

from pydantic import Field, model_validator

from helixd.config.control import ControlConfig
from helixd.config.fields import ConfigSection
from helixd.config.link import LinkConfig
from helixd.config.media import GroundConfig, MediaConfig
from helixd.config.mission import MissionLimits, PlanningConfig
from helixd.config.recorder import GcsReportConfig, PayloadConfig, RecorderConfig
from helixd.config.safety import GPS_FIX_PERIOD_MAX_S, SafetyConfig, StartupConfig
from helixd.config.serve import ServeConfig
from helixd.config.vehicle import ActuationBackend, ActuationConfig, VehicleConfig


class HelixdConfig(ConfigSection):
    vehicle: VehicleConfig = Field(default_factory=VehicleConfig)
    control: ControlConfig = Field(default_factory=ControlConfig)
    mission: MissionLimits = Field(default_factory=MissionLimits)
    link: LinkConfig = Field(default_factory=LinkConfig)
    actuation: ActuationConfig = Field(default_factory=ActuationConfig)
    safety: SafetyConfig = Field(default_factory=SafetyConfig)
    startup: StartupConfig = Field(default_factory=StartupConfig)
    recorder: RecorderConfig = Field(default_factory=RecorderConfig)
    planning: PlanningConfig = Field(default_factory=PlanningConfig)
    gcs_report: GcsReportConfig = Field(default_factory=GcsReportConfig)
    serve: ServeConfig = Field(default_factory=ServeConfig)
    media: MediaConfig = Field(default_factory=MediaConfig)
    payload: PayloadConfig = Field(default_factory=PayloadConfig)
    ground: GroundConfig = Field(default_factory=GroundConfig)

    @model_validator(mode="after")
    def _consistent(self) -> HelixdConfig:
        problems = config_consistency_problems(self)
        if problems:
            raise ValueError("\n".join(problems))
        return self


def config_consistency_problems(cfg: HelixdConfig) -> list[str]:
    """Rules that relate fields of different sections; one line per problem, naming both."""
    problems: list[str] = []
    act, saf = cfg.actuation, cfg.safety
    if act.stop_timeout_s >= saf.fallback_deadline_s:
        problems.append(
            f"actuation.stop_timeout_s = {act.stop_timeout_s} s must be < "
            f"safety.fallback_deadline_s = {saf.fallback_deadline_s} s (stopping the scrolls "
            "is one step of the fall-back that must finish within the deadline)"
        )
    if act.backend is ActuationBackend.RC_OVERRIDE:
        release_s = act.neutral_hold_s + (act.release_repeats - 1) * act.release_spacing_s
        if release_s >= act.stop_timeout_s:
            problems.append(
                f"actuation.neutral_hold_s + (release_repeats - 1) × release_spacing_s = "
                f"{release_s:.3f} s must be < actuation.stop_timeout_s = {act.stop_timeout_s} s "
                "(otherwise the release is cut off by the stop timeout)"
            )
    min_period_s = 1.0 / cfg.link.pose_rate_min_hz
    if saf.pose_stale_s <= min_period_s:
        problems.append(
            f"safety.pose_stale_s = {saf.pose_stale_s} s must be > 1 / link.pose_rate_min_hz = "
            f"{min_period_s:.3f} s (at the slowest accepted pose rate every pose would be stale)"
        )
    # the telemetry streams are stepped down no lower than this when the autopilot refuses
    telemetry_floor_hz = min(cfg.link.telemetry_rate_hz, cfg.link.pose_rate_min_hz)
    gps_gap_s = 1.0 / telemetry_floor_hz + GPS_FIX_PERIOD_MAX_S
    if saf.gps_stale_s <= gps_gap_s:
        problems.append(
            f"safety.gps_stale_s = {saf.gps_stale_s} s must be > 1 / min(link.telemetry_rate_hz, "
            f"link.pose_rate_min_hz) + {GPS_FIX_PERIOD_MAX_S} s = {gps_gap_s:.3f} s (GPS_RAW_INT "
            "comes at the telemetry rate, stepped down no lower than that; a new fix in it at "
            "least every 0.2 s, ArduPilot's slowest GPS_RATE_MS)"
        )
    if cfg.serve.switch_stale_s <= 1.0 / telemetry_floor_hz:
        problems.append(
            f"serve.switch_stale_s = {cfg.serve.switch_stale_s} s must be > 1 / "
            f"min(link.telemetry_rate_hz, link.pose_rate_min_hz) = {1.0 / telemetry_floor_hz:.3f}"
            " s (RC_CHANNELS comes at the telemetry rate, stepped down no lower than that)"
        )
    telemetry_period_s = 1.0 / cfg.link.telemetry_rate_hz
    if cfg.serve.target_stale_s <= telemetry_period_s:
        problems.append(
            f"serve.target_stale_s = {cfg.serve.target_stale_s} s must be > 1 / "
            f"link.telemetry_rate_hz = {telemetry_period_s:.3f} s (POSITION_TARGET_GLOBAL_INT "
            "comes at the telemetry rate)"
        )
    sta = cfg.startup
    if sta.arm_retry_interval_s > sta.arm_timeout_s:
        problems.append(
            f"startup.arm_retry_interval_s = {sta.arm_retry_interval_s} s must be <= "
            f"startup.arm_timeout_s = {sta.arm_timeout_s} s"
        )
    problems.extend(_channel_conflicts(cfg))
    return problems


def _channel_conflicts(cfg: HelixdConfig) -> list[str]:
    act, sta, tk = cfg.actuation, cfg.startup, cfg.safety.takeover
    problems: list[str] = []
    scrolls = {c.channel: i for i, c in enumerate(act.channels)}
    pilot: list[tuple[str, int]] = []
    if tk.switch_channel is not None:
        pilot.append(("safety.takeover.switch_channel", tk.switch_channel))
    if sta.start_switch_channel is not None:
        pilot.append(("startup.start_switch_channel", sta.start_switch_channel))
    pilot.extend(
        (f"safety.takeover.stick_channels.{i}", ch) for i, ch in enumerate(tk.stick_channels)
    )
    if act.backend is ActuationBackend.RC_OVERRIDE:
        for name, ch in pilot:
            if ch in scrolls:
                problems.append(
                    f"{name} = {ch} is the RC channel that drives scroll {scrolls[ch] + 1} "
                    f"(actuation.channels.{scrolls[ch]}.channel): our own override would read as "
                    f"the pilot's input; allowed: a channel 1..18 other than {sorted(scrolls)}"
                )
    if (
        tk.switch_channel is not None
        and sta.start_switch_channel is not None
        and tk.switch_channel == sta.start_switch_channel
    ):
        problems.append(
            f"safety.takeover.switch_channel and startup.start_switch_channel are both "
            f"{tk.switch_channel}: flipping the start switch would be read as a takeover"
        )
    for name, ch in pilot[:2]:
        if name == "startup.start_switch_channel" and ch in tk.stick_channels:
            problems.append(
                f"startup.start_switch_channel = {ch} is also in safety.takeover.stick_channels: "
                "flipping the start switch would be read as a stick deflection"
            )
    return problems
