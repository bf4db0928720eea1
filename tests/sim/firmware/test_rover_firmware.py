"""ArduPilot Rover behaviour model (pure): overrides, outputs, DO_SET_SERVO, modes, failsafes."""

from __future__ import annotations

from typing import Any

import pytest

from helixd.mav.arming import FORCE_ARM_MAGIC
from helixd.mav.constants import (
    MAV_CMD_COMPONENT_ARM_DISARM,
    MAV_CMD_DO_SET_HOME,
    MAV_CMD_DO_SET_SERVO,
    MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN,
    MAV_RESULT_ACCEPTED,
    MAV_RESULT_DENIED,
    MAV_RESULT_FAILED,
    MAV_RESULT_UNSUPPORTED,
    UINT16_MAX,
)
from helixd.mav.guard_script import SCRIPT_NAME, VERSION, script_bytes
from helixd.sim.firmware import estimator, modes
from helixd.sim.firmware import guard_model as g
from helixd.sim.firmware.param_store import ParamStore
from helixd.sim.firmware.rover_firmware import FORCE_REBOOT_MAGIC, SimAutopilot
from helixd.sim.sim_config import HELIXD_SYSID, SimConfig

DT_S = 0.02
BOOT_S = 2.0
NOT_SET = UINT16_MAX  # channels 1–8: leave unchanged
GCS = HELIXD_SYSID  # the simulator's MAV_GCS_SYSID for helixd (ArduPilot's default is 255)


def healthy_ekf() -> estimator.SimEkfStatus:
    profile = SimConfig().noise_profiles.none
    return estimator.ekf_status(estimator.EstimatorState(), profile, True, False)


def bad_ekf() -> estimator.SimEkfStatus:
    profile = SimConfig().noise_profiles.none
    return estimator.ekf_status(estimator.EstimatorState(), profile, True, True)


class Rig:
    """An SimAutopilot plus a simulated clock stepping at 50 Hz."""

    def __init__(self, scripts: dict[str, bytes] | None = None, **config: Any) -> None:
        cfg = SimConfig.model_validate(
            {"boot_duration_s": BOOT_S, "ekf_origin_delay_s": 0.5, "prearm_delay_s": 5.0, **config}
        )
        self.scripts = dict(scripts or {})
        self.ap = SimAutopilot(
            cfg, ParamStore(cfg.params, stored=cfg.guard_params), 0.0, lambda: self.scripts
        )
        self.now = 0.0
        self.ekf = healthy_ekf()
        self.outputs: list[int] = [0] * 16

    def run(self, seconds: float, each: Any = None) -> None:
        for _ in range(round(seconds / DT_S)):
            self.now = round(self.now + DT_S, 9)
            if each is not None:
                each(self)
            self.outputs = self.ap.step(self.now, self.ekf)
            # the EKF's position, as the core feeds it (home follows it; at the origin here)
            ready = self.ap.origin_set(self.now) and not self.ap.booting(self.now)
            self.ap.observe_position(self.now, 0.0, 0.0, ready)

    def boot(self) -> Rig:
        self.run(BOOT_S + 0.6)
        assert self.ap.mode == modes.MANUAL
        return self

    def override(self, *channels: int, sysid: int = GCS) -> None:
        raw = list(channels) + [NOT_SET] * max(0, 8 - len(channels))
        raw += [0] * (18 - len(raw))
        self.ap.on_rc_override(sysid, raw, self.now)

    def command(self, command: int, *p: float) -> int | None:
        params = [float(x) for x in p] + [0.0] * (7 - len(p))
        return self.ap.command(command, params, self.now, self.ekf)

    def force_arm(self) -> None:
        assert self.command(MAV_CMD_COMPONENT_ARM_DISARM, 1, FORCE_ARM_MAGIC) == 0

    def texts(self) -> list[str]:
        return [t.text for t in self.ap.texts]

    def kinds(self) -> list[str]:
        return [e.kind for e in self.ap.events]


def test_boot_is_initialising_then_manual() -> None:
    rig = Rig()
    rig.run(BOOT_S - 0.1)
    assert rig.ap.mode == modes.INITIALISING
    assert rig.outputs == [0] * 16  # no PWM while booting
    rig.run(0.2)
    assert rig.ap.mode == modes.MANUAL
    assert rig.outputs[:4] == [1500] * 4  # RCIN1..4 passthrough of the pilot's sticks


def test_override_from_non_gcs_sysid_is_ignored() -> None:
    rig = Rig().boot()
    rig.override(1800, sysid=1)
    rig.run(0.1)
    assert rig.outputs[0] == 1500
    assert "override_set" not in rig.kinds()


def test_override_from_gcs_drives_passthrough_while_disarmed() -> None:
    rig = Rig().boot()
    assert not rig.ap.armed
    rig.override(1800, 1200)
    rig.run(0.04)
    assert rig.outputs[:4] == [1800, 1200, 1500, 1500]


def test_gcs_sysid_range_with_hi_param() -> None:
    rig = Rig(params={"MAV_GCS_SYSID": 250, "MAV_GCS_SYSID_HI": 252}).boot()
    rig.override(1700, sysid=251)
    rig.run(0.04)
    assert rig.outputs[0] == 1700
    rig.override(1600, sysid=255)
    rig.run(0.04)
    assert rig.outputs[0] == 1700


def test_channels_1_to_8_zero_releases_and_uint16max_leaves_unchanged() -> None:
    rig = Rig().boot()
    rig.override(1800, 1800)
    rig.run(0.04)
    rig.override(NOT_SET, 0)  # ch1 unchanged, ch2 released
    rig.run(0.02)
    assert rig.outputs[:2] == [1800, 1500]
    assert rig.ap.rc.active_overrides(rig.now, 3.0)[:2] == (True, False)


def test_channels_9_to_16_zero_unchanged_and_65534_releases() -> None:
    rig = Rig(params={"SERVO9_FUNCTION": 59}).boot()  # RCIN9 passthrough on output 9
    raw = [NOT_SET] * 8 + [1900] + [0] * 9
    rig.ap.on_rc_override(GCS, raw, rig.now)
    rig.run(0.04)
    assert rig.outputs[8] == 1900
    for keep in (0, UINT16_MAX):
        rig.ap.on_rc_override(GCS, [NOT_SET] * 8 + [keep] + [0] * 9, rig.now)
        rig.run(0.04)
        assert rig.outputs[8] == 1900
    rig.ap.on_rc_override(GCS, [NOT_SET] * 8 + [UINT16_MAX - 1] + [0] * 9, rig.now)
    rig.run(0.02)
    assert rig.outputs[8] == 1500


def test_channels_17_and_18_do_not_exist() -> None:
    rig = Rig().boot()
    rig.ap.on_rc_override(GCS, [NOT_SET] * 16 + [1900, 1900], rig.now)
    assert not any(rig.ap.rc.override_us)


def test_override_expires_after_rc_override_time_per_channel() -> None:
    rig = Rig().boot()
    rig.override(1800)
    rig.run(1.0)
    rig.override(NOT_SET, 1700)  # ch2 set 1 s later, ch1 not refreshed
    rig.run(1.96)
    assert rig.outputs[:2] == [1800, 1700]
    rig.run(0.06)  # 3.02 s after ch1 was last set
    assert rig.outputs[:2] == [1500, 1700]
    rig.run(1.0)
    assert rig.outputs[:2] == [1500, 1500]
    assert rig.kinds().count("override_expire") == 2


@pytest.mark.parametrize(("timeout_s", "active_after_10_s"), [(-1.0, True), (0.0, False)])
def test_rc_override_time_negative_never_expires_zero_disables(
    timeout_s: float, active_after_10_s: bool
) -> None:
    # GCS failsafe off: it would clear the override after FS_GCS_TIMEOUT without heartbeats
    rig = Rig(params={"RC_OVERRIDE_TIME": timeout_s, "FS_GCS_ENABLE": 0}).boot()
    rig.override(1800)
    rig.run(10.0)
    assert (rig.outputs[0] == 1800) is active_after_10_s


def test_rc_options_ignore_overrides() -> None:
    rig = Rig(params={"RC_OPTIONS": 2}).boot()
    rig.override(1800)
    rig.run(0.1)
    assert rig.outputs[0] == 1500


def test_hold_and_disarm_do_not_stop_passthrough_outputs() -> None:
    rig = Rig().boot()
    rig.force_arm()
    rig.override(1800, 1800, 1200, 1200)
    rig.run(0.1)
    assert rig.ap.set_mode(modes.HOLD, "test", rig.now, rig.ekf)
    rig.override(1800, 1800, 1200, 1200)
    rig.run(0.5)
    assert rig.ap.mode == modes.HOLD
    assert rig.outputs[:4] == [1800, 1800, 1200, 1200]
    assert rig.command(MAV_CMD_COMPONENT_ARM_DISARM, 0) == MAV_RESULT_ACCEPTED
    rig.run(0.5)
    assert rig.outputs[:4] == [1800, 1800, 1200, 1200]


def test_hold_zeroes_ardupilots_own_throttle_output() -> None:
    # stock Rover: throttle on output 3, from RC input 3
    rig = Rig(params={"SERVO3_FUNCTION": 70, "RCMAP_THROTTLE": 3}).boot()
    rig.force_arm()
    rig.override(NOT_SET, NOT_SET, 1900)
    rig.run(0.1)
    assert rig.outputs[2] > 1800
    rig.ap.set_mode(modes.HOLD, "test", rig.now, rig.ekf)
    rig.override(NOT_SET, NOT_SET, 1900)
    rig.run(0.1)
    assert rig.outputs[2] == 1500


def test_do_set_servo_refused_unless_function_allows_it() -> None:
    rig = Rig(params={"SERVO5_FUNCTION": 73}).boot()
    assert rig.command(MAV_CMD_DO_SET_SERVO, 5, 1700) == MAV_RESULT_FAILED
    assert "ServoRelayEvent: Channel 5 is already in use" in rig.texts()
    assert rig.command(MAV_CMD_DO_SET_SERVO, 17, 1700) == MAV_RESULT_FAILED
    for function in (0, 1, 22, 23, 28, 51, 66):
        rig.ap.params.set("SERVO6_FUNCTION", function)
        assert rig.command(MAV_CMD_DO_SET_SERVO, 6, 1600) == MAV_RESULT_ACCEPTED
    for function in (26, 70, 74, 33):
        rig.ap.params.set("SERVO6_FUNCTION", function)
        assert rig.command(MAV_CMD_DO_SET_SERVO, 6, 1600) == MAV_RESULT_FAILED


def test_do_set_servo_latches_forever_even_after_disarm() -> None:
    rig = Rig().boot()
    rig.force_arm()
    assert rig.command(MAV_CMD_DO_SET_SERVO, 6, 1234) == MAV_RESULT_ACCEPTED
    rig.run(5.0)
    rig.command(MAV_CMD_COMPONENT_ARM_DISARM, 0)
    rig.ap.set_mode(modes.HOLD, "test", rig.now, rig.ekf)
    rig.run(60.0)
    assert rig.outputs[5] == 1234
    assert rig.ap.outputs.latched_channels() == (6,)


def test_do_set_servo_on_passthrough_holds_until_rc_moves_beyond_dead_zone() -> None:
    rig = Rig().boot()
    assert rig.command(MAV_CMD_DO_SET_SERVO, 2, 1650) == MAV_RESULT_ACCEPTED
    rig.run(1.0)
    assert rig.outputs[1] == 1650  # RC2 still 1500: latched
    rig.ap.set_pilot_rc(2, 1520)  # RC2_DZ is 0: any change resumes passthrough
    rig.run(0.04)
    assert rig.outputs[1] == 1520


def test_arming_is_refused_until_home_is_set_then_accepted() -> None:
    """AP_Arming::gps_checks: "AHRS: waiting for home" until Rover::ahrs_update sets home
    from the EKF's first position ("Set HOME to …"); nothing else holds arming back here."""
    rig = Rig(ekf_origin_delay_s=3.0, prearm_delay_s=0.0)
    rig.run(BOOT_S + 0.1)
    assert rig.ap.mode == modes.MANUAL and not rig.ap.home_set(rig.now)
    assert rig.command(MAV_CMD_COMPONENT_ARM_DISARM, 1) == MAV_RESULT_FAILED
    assert rig.texts()[-1] == "PreArm: AHRS: waiting for home"
    rig.run(3.0)
    assert rig.ap.home_set(rig.now)
    assert "Set HOME to 53.523250 -113.526320 at 668.00m" in rig.texts()
    assert rig.command(MAV_CMD_COMPONENT_ARM_DISARM, 1) == MAV_RESULT_ACCEPTED
    assert rig.ap.armed


def test_by_default_arming_is_accepted_as_soon_as_home_is_set() -> None:
    """The built-in simulator's defaults (`run --sim`, `make demo`): nothing but home holds
    arming back, as on ArduPilot once its EKF has a position — so a demo arms without a
    refusal (it used to refuse "waiting for home" for 20 s after home was set)."""
    cfg = SimConfig()
    ap = SimAutopilot(cfg, ParamStore(cfg.params), 0.0)
    now, ekf = 0.0, healthy_ekf()
    while not ap.home_set(now):
        now = round(now + DT_S, 9)
        ap.step(now, ekf)
        ap.observe_position(now, 0.0, 0.0, ap.origin_set(now) and not ap.booting(now))
    assert now == pytest.approx(cfg.boot_duration_s + cfg.ekf_origin_delay_s, abs=DT_S)
    assert ap.arm_disarm(1.0, 0.0, now, ekf) == MAV_RESULT_ACCEPTED


def test_do_set_home_here_once_the_ekf_has_a_position() -> None:
    rig = Rig(home_delay_s=None, ekf_origin_delay_s=2.0, prearm_delay_s=0.0)
    rig.run(BOOT_S + 0.1)
    assert rig.command(MAV_CMD_DO_SET_HOME, 1) == MAV_RESULT_FAILED  # no position yet
    rig.run(2.0)
    assert not rig.ap.home_set(rig.now)
    # a location is taken, as ArduPilot takes it (DO_SET_HOME at a place)
    assert rig.command(MAV_CMD_DO_SET_HOME, 0, 0, 0, 0, 53.5, -113.5) == MAV_RESULT_ACCEPTED
    assert rig.ap.home_set(rig.now) and rig.texts()[-1].startswith("Set HOME to 53.500000")
    assert rig.command(MAV_CMD_DO_SET_HOME, 1) == MAV_RESULT_ACCEPTED
    rig.run(0.04)
    assert rig.ap.home_set(rig.now) and rig.texts()[-1].startswith("Set HOME to ")
    assert rig.command(MAV_CMD_COMPONENT_ARM_DISARM, 1) == MAV_RESULT_ACCEPTED


def test_home_never_set_only_force_arms() -> None:
    rig = Rig(home_delay_s=None).boot()
    rig.run(60.0)
    assert rig.command(MAV_CMD_COMPONENT_ARM_DISARM, 1) == MAV_RESULT_FAILED
    assert rig.texts()[-1] == "PreArm: AHRS: waiting for home"
    assert not any(t.startswith("Set HOME") for t in rig.texts())
    rig.force_arm()
    assert rig.ap.armed


def test_arming_prearm_refusal_force_and_later_success() -> None:
    rig = Rig().boot()  # home set; the other PreArm checks pass 5 s after boot
    assert rig.command(MAV_CMD_COMPONENT_ARM_DISARM, 1) == MAV_RESULT_FAILED
    assert rig.texts()[-1] == "PreArm: AHRS: EKF3 still initialising"
    rig.force_arm()
    assert rig.ap.armed
    assert rig.command(MAV_CMD_COMPONENT_ARM_DISARM, 0) == MAV_RESULT_ACCEPTED
    rig.run(5.0)
    assert rig.command(MAV_CMD_COMPONENT_ARM_DISARM, 1) == MAV_RESULT_ACCEPTED
    assert rig.command(MAV_CMD_COMPONENT_ARM_DISARM, 2) == MAV_RESULT_UNSUPPORTED


def test_prearm_never_passes_when_configured() -> None:
    rig = Rig(prearm_delay_s=None).boot()
    rig.run(100.0)
    assert rig.command(MAV_CMD_COMPONENT_ARM_DISARM, 1) == MAV_RESULT_FAILED


def test_set_mode_needs_custom_mode_flag_and_known_mode() -> None:
    rig = Rig().boot()
    assert rig.ap.do_set_mode(0, modes.HOLD, rig.now, rig.ekf) == MAV_RESULT_DENIED
    assert rig.ap.do_set_mode(1, 99, rig.now, rig.ekf) == MAV_RESULT_FAILED
    assert rig.ap.do_set_mode(1, modes.AUTO, rig.now, rig.ekf) == MAV_RESULT_FAILED  # no mission
    assert rig.ap.do_set_mode(1, modes.HOLD, rig.now, rig.ekf) == MAV_RESULT_ACCEPTED
    assert rig.ap.mode == modes.HOLD


def test_armed_position_modes_refused_without_ekf_position() -> None:
    rig = Rig().boot()
    rig.force_arm()
    rig.ekf = bad_ekf()
    assert rig.ap.do_set_mode(1, modes.GUIDED, rig.now, rig.ekf) == MAV_RESULT_FAILED
    assert rig.ap.do_set_mode(1, modes.HOLD, rig.now, rig.ekf) == MAV_RESULT_ACCEPTED


def test_pilot_mode_switch_takes_over_after_debounce() -> None:
    rig = Rig().boot()
    rig.ap.set_pilot_rc(8, 1900)  # MODE6 = HOLD in the Helix setup
    rig.run(0.1)
    assert rig.ap.mode == modes.MANUAL
    rig.run(0.2)
    assert rig.ap.mode == modes.HOLD
    rig.ap.set_pilot_rc(8, 1100)  # MODE1 = MANUAL
    rig.run(0.4)
    assert rig.ap.mode == modes.MANUAL


def test_radio_loss_failsafe_holds_clears_overrides_and_freezes_outputs() -> None:
    rig = Rig().boot()
    rig.force_arm()
    rig.override(1700, 1700, 1300, 1300)
    rig.run(0.1)
    rig.ap.set_receiver_ok(False)
    rig.run(2.4)  # RC_FS_TIMEOUT 1 s + FS_TIMEOUT 1.5 s not yet over
    assert rig.ap.mode == modes.MANUAL
    rig.run(0.3)
    assert rig.ap.mode == modes.HOLD
    assert "Radio Failsafe" in rig.texts()
    assert not any(rig.ap.rc.active_overrides(rig.now, -1.0))
    # ArduPilot never re-reads RC after clear_overrides without a new frame: the RCIN
    # passthrough outputs stay at the last override — HOLD does not stop the scrolls.
    assert rig.outputs[:4] == [1700, 1700, 1300, 1300]
    rig.ap.set_receiver_ok(True)
    rig.run(0.1)
    assert rig.outputs[:4] == [1500] * 4
    assert "Radio Failsafe Cleared" in rig.texts()


def test_streaming_overrides_keep_radio_failsafe_away() -> None:
    """RC_Channels::read_input counts a new override as valid RC input (faithful port)."""
    rig = Rig().boot()
    rig.ap.set_receiver_ok(False)

    def keep_overriding(r: Rig) -> None:
        if round(r.now / DT_S) % 5 == 0:
            r.override(1600)

    rig.run(10.0, keep_overriding)
    assert rig.ap.mode == modes.MANUAL
    assert not rig.ap.failsafes.radio_on()


def test_throttle_below_fs_thr_value_is_radio_failsafe() -> None:
    rig = Rig().boot()
    assert rig.ap.params.get_int("RCMAP_THROTTLE") == 5  # the Helix setup: not overridden
    rig.ap.set_pilot_rc(5, 900)  # receiver's own failsafe value on throttle
    rig.run(1.6)
    assert rig.ap.mode == modes.HOLD


def test_gcs_failsafe_after_fs_gcs_timeout_plus_fs_timeout() -> None:
    rig = Rig(params={"FS_GCS_ENABLE": 1}).boot()
    rig.ap.on_heartbeat(1, rig.now)  # not the GCS sysid: does not count
    rig.run(10.0)
    assert rig.ap.mode == modes.MANUAL
    rig.ap.on_heartbeat(GCS, rig.now)
    lost_at = rig.now
    rig.run(6.3)  # 5 s + 1.5 s, checked at 10 Hz
    assert rig.ap.mode == modes.MANUAL
    rig.run(0.4)
    assert rig.ap.mode == modes.HOLD
    assert 6.4 <= rig.now - lost_at <= 6.8
    fired = [e for e in rig.ap.events if e.kind == "failsafe"]
    assert [e.details["causes"] for e in fired] == [["gcs"]]
    # ArduPilot's text names whichever check ran first (often "Radio Failsafe")
    assert any(t.endswith(" Failsafe") for t in rig.texts())


def test_gcs_failsafe_disabled_by_default_and_never_in_hold() -> None:
    rig = Rig(params={"FS_GCS_ENABLE": 0}).boot()  # ArduPilot's default
    rig.ap.on_heartbeat(GCS, rig.now)
    rig.run(20.0)
    assert rig.ap.mode == modes.MANUAL
    rig2 = Rig(params={"FS_GCS_ENABLE": 1}).boot()
    rig2.ap.set_mode(modes.HOLD, "test", rig2.now, rig2.ekf)
    rig2.override(1800)  # also counts as GCS contact
    rig2.run(10.0)
    assert rig2.ap.failsafes.gcs_on()
    assert rig2.ap.failsafes.triggered == 0  # not triggered in HOLD (FS_OPTIONS 0)


def test_ekf_failsafe_leaves_manual_alone_but_holds_guided() -> None:
    rig = Rig().boot()
    rig.force_arm()
    rig.ekf = bad_ekf()
    rig.run(2.0)
    assert rig.ap.mode == modes.MANUAL
    assert rig.ap.failsafes.ekf_failsafe
    assert "EKF variance" in rig.texts()
    rig2 = Rig().boot()
    rig2.force_arm()
    assert rig2.ap.set_mode(modes.GUIDED, "test", rig2.now, rig2.ekf)
    rig2.ekf = bad_ekf()
    rig2.run(0.9)
    assert rig2.ap.mode == modes.GUIDED
    rig2.run(0.3)
    assert rig2.ap.mode == modes.HOLD
    assert "EKF failsafe" in rig2.texts()


def test_reboot_keeps_params_and_restarts_boot() -> None:
    rig = Rig().boot()
    rig.ap.params.set("FS_GCS_ENABLE", 1)
    rig.force_arm()
    rig.ap.reboot(rig.now, 1.0)
    assert rig.ap.silent(rig.now + 0.5)
    assert rig.ap.booting(rig.now + 1.5)
    assert rig.ap.time_boot_ms(rig.now + 1.5) == 500
    assert not rig.ap.armed
    assert rig.ap.params.get("FS_GCS_ENABLE") == 1.0


def test_the_reboot_command_is_refused_while_armed_unless_forced_as_ardupilot_does() -> None:
    """GCS_MAVLINK::handle_preflight_reboot: armed → FAILED unless param6 (y) is 20190226;
    param1 other than 1 or 3 → UNSUPPORTED; else ACCEPTED (the core reboots after the ACK)."""
    rig = Rig().boot()
    assert rig.command(MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, 2) == MAV_RESULT_UNSUPPORTED
    assert rig.command(MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, 1) == MAV_RESULT_ACCEPTED
    rig.force_arm()
    assert rig.command(MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, 1) == MAV_RESULT_FAILED
    assert rig.command(MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, 1, 0, 0, 0, 0, 20190) == (
        MAV_RESULT_FAILED
    )
    forced = rig.command(MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, 1, 0, 0, 0, 0, FORCE_REBOOT_MAGIC)
    assert forced == MAV_RESULT_ACCEPTED


def test_expired_override_leaves_outputs_frozen_while_receiver_is_lost() -> None:
    """Without RC frames nothing re-reads radio_in: a companion that dies during RC loss
    leaves the scrolls at its last command — only an explicit neutral/release helps."""
    rig = Rig().boot()
    rig.ap.set_receiver_ok(False)
    rig.override(1800)
    rig.run(10.0)  # override long expired, radio failsafe → HOLD, overrides cleared
    assert rig.ap.mode == modes.HOLD
    assert not rig.ap.rc.active_overrides(rig.now, 3.0)[0]
    assert rig.outputs[0] == 1800
    rig.override(1500)  # a neutral override is still obeyed ...
    rig.run(0.04)
    assert rig.outputs[0] == 1500
    rig.override(1800)
    rig.run(0.04)
    rig.override(0)  # ... and a release falls back to the last frame the receiver gave
    rig.run(0.04)
    assert rig.outputs[0] == 1500


# --- scripting: helixd-guard.lua ---------------------------------------------------------------

GUARD = {SCRIPT_NAME: script_bytes()}
SERVO_BACKEND = {f"SERVO{n}_FUNCTION": 0 for n in range(1, 5)}


def guarded(**config: Any) -> Rig:
    params = {"SCR_ENABLE": 1, **config.pop("params", {})}
    return Rig(scripts=config.pop("scripts", GUARD), params=params, **config).boot()


def heartbeat_until(seconds: float) -> Any:
    """A step hook: helixd's HEARTBEAT every 0.2 s (5 Hz) until ``seconds`` of simulated time."""

    def each(rig: Rig) -> None:
        if rig.now <= seconds and round(rig.now / DT_S) % 10 == 0:
            rig.ap.on_heartbeat(GCS, rig.now)

    return each


def test_guard_loads_at_boot_with_scripting_on() -> None:
    rig = guarded()
    assert rig.ap.guard is not None and rig.ap.guard.version == VERSION
    assert "helixd-guard: v1 on, outputs 1 2 3 4, 500 ms" in rig.texts()
    params = rig.ap.params
    assert [params.get(f"HXG_{n}") for n in ("ENABLE", "TIMEOUT", "CHAN1", "CHAN4")] == [
        1.0,
        0.5,
        1.0,
        4.0,
    ]
    assert params.get("HXG_VERSION") == VERSION


@pytest.mark.parametrize(
    ("scr_enable", "scripts"),
    [(0, GUARD), (1, {}), (1, {"other.lua": b"return"})],
    ids=["scripting_off", "no_script", "another_script"],
)
def test_no_guard_without_scripting_or_script(scr_enable: int, scripts: dict[str, bytes]) -> None:
    rig = Rig(scripts=scripts, params={"SCR_ENABLE": scr_enable}).boot()
    assert rig.ap.guard is None
    assert "HXG_VERSION" not in rig.ap.params
    rig.force_arm()
    rig.run(2.0)  # armed, no helixd: nothing holds the outputs
    assert rig.ap.mode == modes.MANUAL


def test_scr_enable_takes_effect_at_the_next_boot() -> None:
    rig = Rig(scripts=GUARD).boot()
    rig.ap.params.set("SCR_ENABLE", 1)
    rig.run(1.0)
    assert rig.ap.guard is None
    rig.ap.reboot(rig.now, 0.5)
    rig.run(BOOT_S + 1.0)
    assert rig.ap.guard is not None


def test_guard_version_is_the_files() -> None:
    old = script_bytes().replace(b"local VERSION = 1\n", b"local VERSION = 0\n")
    rig = guarded(scripts={SCRIPT_NAME: old})
    assert rig.ap.params.get("HXG_VERSION") == 0.0
    rig.ap.params.set("HXG_VERSION", 5)  # the script re-asserts its own
    rig.run(0.1)
    assert rig.ap.params.get("HXG_VERSION") == 0.0


def test_guard_params_from_storage_survive_a_reboot_but_vanish_without_the_script() -> None:
    rig = guarded(guard_params={"HXG_TIMEOUT": 0.3})
    assert rig.ap.params.get("HXG_TIMEOUT") == pytest.approx(0.3)
    rig.ap.params.set("HXG_CHAN2", 0)
    rig.ap.reboot(rig.now, 0.5)
    assert "HXG_CHAN2" not in rig.ap.params  # gone until the script adds it again
    rig.run(BOOT_S + 1.0)
    assert rig.ap.params.get("HXG_CHAN2") == 0.0
    assert "helixd-guard: v1 on, outputs 1 3 4, 300 ms" in rig.texts()


def test_killed_helixd_servo_outputs_trim_and_hold_within_the_timeout() -> None:
    rig = guarded(params=SERVO_BACKEND)
    rig.run(0.4, heartbeat_until(1e9))
    rig.force_arm()
    for ch in (1, 2, 3, 4):
        assert rig.command(MAV_CMD_DO_SET_SERVO, ch, 1600) == MAV_RESULT_ACCEPTED
    last_hb = rig.now + 1.0
    rig.run(1.0, heartbeat_until(last_hb))  # 5 Hz heartbeats never trip the guard
    assert rig.outputs[:4] == [1600] * 4 and rig.ap.mode == modes.MANUAL
    assert not any(t.startswith(g.TEXT_PREFIX + "no heartbeat") for t in rig.texts())
    trim_at = hold_at = None
    while rig.now < last_hb + 2.0:
        rig.run(DT_S)
        if trim_at is None and rig.outputs[:4] == [1500] * 4:
            trim_at = rig.now
        if hold_at is None and rig.ap.mode == modes.HOLD:
            hold_at = rig.now
    assert trim_at is not None and hold_at is not None
    # silent > 500 ms, noticed at the next 50 ms update, applied in that main loop
    assert 0.5 < trim_at - last_hb <= 0.5 + 0.05 + DT_S + 1e-9
    assert hold_at == trim_at
    assert "helixd-guard: no heartbeat 500 ms, trim + HOLD" in rig.texts()
    assert rig.outputs[:4] == [1500] * 4  # renewed while the silence lasts


def test_do_set_servo_while_the_guard_holds_is_accepted_but_ignored() -> None:
    rig = guarded(params=SERVO_BACKEND)
    rig.force_arm()  # no helixd heard since boot: the guard holds at once
    rig.run(0.1)
    assert rig.ap.mode == modes.HOLD and g.NEVER_SEEN_TEXT in rig.texts()
    assert rig.command(MAV_CMD_DO_SET_SERVO, 1, 1700) == MAV_RESULT_ACCEPTED
    rig.run(0.1)
    assert rig.outputs[0] == 1500
    rig.run(0.3, heartbeat_until(1e9))  # helixd back: released, the output keeps trim …
    assert g.BACK_TEXT in rig.texts()
    rig.run(0.4, heartbeat_until(1e9))
    assert rig.outputs[0] == 1500
    assert rig.command(MAV_CMD_DO_SET_SERVO, 1, 1700) == MAV_RESULT_ACCEPTED  # … until re-sent
    rig.run(0.04, heartbeat_until(1e9))
    assert rig.outputs[0] == 1700


def passthrough_overridden() -> Rig:
    """A guarded autopilot whose output 2 follows RC input 1, armed, helixd's heartbeat
    flowing, RC input 1 overridden to 1700 µs: both outputs at 1700."""
    rig = guarded(params={"SERVO2_FUNCTION": 51})  # output 2 follows RC input 1
    rig.run(0.2, heartbeat_until(1e9))
    rig.force_arm()
    rig.override(1700, 1800)
    rig.run(0.1)
    assert rig.outputs[:2] == [1700, 1700]
    return rig


def test_guard_holds_rc_passthrough_by_overriding_its_input() -> None:
    """RCIN passthrough copies the input after the servo override: the guard overrides RC
    input n at trim, outliving RC_OVERRIDE_TIME while helixd stays silent."""
    rig = passthrough_overridden()
    rig.ap.set_pilot_rc(1, 1650)  # the pilot's stick is no override
    rig.run(8.0)  # helixd dead: guard on after 0.5 s, RC_OVERRIDE_TIME (3 s) long past
    assert rig.outputs[:4] == [1500, 1500, 1500, 1500]
    assert rig.ap.rc.active_overrides(rig.now, 3.0)[0]  # the guard's own override
    assert rig.ap.mode == modes.HOLD
    assert rig.ap.gcs_last_seen_s is not None and rig.ap.gcs_last_seen_s < rig.now - 7.0


def test_guard_disabled_lets_go_and_the_pilot_drives() -> None:
    rig = guarded()
    rig.force_arm()
    rig.ap.set_pilot_rc(1, 1650)
    rig.run(0.5)
    assert rig.outputs[0] == 1500  # armed without helixd: held at trim
    rig.ap.params.set("HXG_ENABLE", 0)
    rig.run(0.1)
    assert g.DISABLED_TEXT in rig.texts()
    rig.run(3.1)  # its last RC override expires with RC_OVERRIDE_TIME
    assert rig.outputs[0] == 1650


def test_pilot_mode_switch_out_of_hold_releases_passthrough_to_the_radio() -> None:
    """After a guard episode (helixd silent, trim + HOLD) the pilot flips the mode switch to
    MANUAL: the guard lets go at once — its RC override cleared, so the radio drives the
    passthrough output now, not RC_OVERRIDE_TIME later — and stays off while helixd is silent."""
    rig = passthrough_overridden()
    rig.ap.set_pilot_rc(1, 1650)
    rig.run(2.0)  # helixd dead: guard on after 0.5 s
    assert rig.outputs[:4] == [1500] * 4 and rig.ap.mode == modes.HOLD
    switched = rig.now
    rig.ap.set_pilot_rc(8, 1100)  # MODE1 = MANUAL
    released_at = None
    while rig.now < switched + 1.0:
        rig.run(DT_S)
        if released_at is None and rig.outputs[:2] == [1650, 1650]:
            released_at = rig.now
    assert rig.ap.mode == modes.MANUAL
    assert released_at is not None
    print(f"sim: mode switch → radio drives outputs 1/2 after {released_at - switched:.2f} s")
    assert released_at - switched < 0.5  # debounce + one 50 ms update, not RC_OVERRIDE_TIME
    assert "helixd-guard: mode 0, pilot in charge, released" in rig.texts()
    assert not rig.ap.rc.active_overrides(rig.now, 3.0)[0]
    rig.ap.set_pilot_rc(1, 1350)  # the radio keeps driving, however long helixd is silent
    rig.run(6.0)
    assert rig.outputs[:2] == [1350, 1350]
    # helixd silent in MANUAL: the GCS failsafe (FS_GCS_TIMEOUT) switches to HOLD; that is no
    # guard episode (it stays released) and HOLD does not stop a passthrough output
    assert rig.ap.mode == modes.HOLD
    assert any(e.kind == "failsafe" for e in rig.ap.events)
    assert sum(t.startswith(g.TEXT_PREFIX + "mode ") for t in rig.texts()) == 1
    # helixd back, then silent again: a new guard episode
    rig.run(0.4, heartbeat_until(rig.now + 0.2))
    assert rig.outputs[:2] == [1350, 1350]
    rig.run(0.6)
    assert rig.outputs[:2] == [1500, 1500] and rig.ap.mode == modes.HOLD
    assert rig.texts().count("helixd-guard: no heartbeat 500 ms, trim + HOLD") == 2


def test_gcs_mode_change_releases_servo_outputs_which_keep_trim() -> None:
    """Servo backend: after the takeover release a function-0 output keeps the held trim (no
    timeout returns it to anything) and a DO_SET_SERVO moves it again at once."""
    rig = guarded(params=SERVO_BACKEND)
    rig.run(0.4, heartbeat_until(1e9))
    rig.force_arm()
    for ch in (1, 2, 3, 4):
        assert rig.command(MAV_CMD_DO_SET_SERVO, ch, 1600) == MAV_RESULT_ACCEPTED
    rig.run(1.0)
    assert rig.outputs[:4] == [1500] * 4 and rig.ap.mode == modes.HOLD
    assert rig.ap.do_set_mode(1, modes.MANUAL, rig.now, rig.ekf) == MAV_RESULT_ACCEPTED
    rig.run(0.1)
    assert "helixd-guard: mode 0, pilot in charge, released" in rig.texts()
    rig.run(5.0)
    assert rig.outputs[:4] == [1500] * 4 and rig.ap.mode == modes.MANUAL
    assert rig.command(MAV_CMD_DO_SET_SERVO, 1, 1700) == MAV_RESULT_ACCEPTED
    rig.run(0.04)
    assert rig.outputs[0] == 1700  # no guard override in the way any more


def test_disarm_after_takeover_release_rearms_the_watch() -> None:
    rig = guarded()
    rig.force_arm()  # no helixd heard: trim + HOLD at once
    rig.run(0.2)
    assert rig.ap.mode == modes.HOLD
    assert rig.ap.do_set_mode(1, modes.MANUAL, rig.now, rig.ekf) == MAV_RESULT_ACCEPTED
    rig.run(0.2)
    assert rig.ap.guard is not None and rig.ap.guard.machine.released_ms is not None
    assert rig.command(MAV_CMD_COMPONENT_ARM_DISARM, 0) == MAV_RESULT_ACCEPTED
    rig.run(0.1)
    assert rig.ap.guard.machine.released_ms is None
    rig.force_arm()
    rig.run(0.1)
    assert rig.ap.mode == modes.HOLD
    assert rig.texts().count(g.NEVER_SEEN_TEXT) == 2


def test_a_throttle_channel_off_its_trim_refuses_the_arm_as_ardupilot() -> None:
    """AP_Arming::rc_arm_checks: after the PreArm checks, RCMAP_THROTTLE's channel (5 in the
    Helix setup) must read RC5_TRIM ± RC5_DZ; a switch resting high refuses the arm."""
    rig = Rig(prearm_delay_s=0.0).boot()
    rig.ap.set_pilot_rc(5, 1900)
    rig.run(0.1)
    assert rig.command(MAV_CMD_COMPONENT_ARM_DISARM, 1) == MAV_RESULT_FAILED
    assert rig.texts()[-1] == "Arm: Throttle (RC5) is not neutral"
    rig.ap.set_pilot_rc(5, 1500)
    rig.run(0.1)
    assert rig.command(MAV_CMD_COMPONENT_ARM_DISARM, 1) == MAV_RESULT_ACCEPTED
