"""Rover radio / GCS / EKF failsafes, ported from ArduPilot (pure; simulated seconds).

* Rover::radio_failsafe_check (Rover/radio.cpp): failed when the throttle channel's radio_in
  < FS_THR_VALUE or no valid RC input (a receiver frame *or a new override*) for
  RC_FS_TIMEOUT. Only with FS_THR_ENABLE ≠ 0.
* Rover::gcs_failsafe_check (Rover/Rover.cpp, 10 Hz): failed when heartbeats (or overrides)
  from the GCS sysid have not been seen for FS_GCS_TIMEOUT, once one was ever seen. Only
  with FS_GCS_ENABLE ≠ 0.
* Rover::failsafe_trigger (Rover/failsafe.cpp): the action fires once the failsafe has been
  on for FS_TIMEOUT, unless already in RTL, or in HOLD (unless FS_OPTIONS bit 0). It sends
  "<type> Failsafe", clears every RC override, then FS_ACTION: 0 none, 1 RTL→HOLD, 2 HOLD,
  3 SmartRTL→RTL→HOLD, 4 SmartRTL→HOLD. "<type> Failsafe Cleared" when it ends.
* Rover::ekf_check (Rover/ekf_check.cpp, 10 Hz, armed only): 10 consecutive bad checks
  (two of compass/velocity/position variance ≥ FS_EKF_THRESH, or no position) → "EKF
  variance"; only modes that need a position are switched to HOLD (FS_EKF_ACTION 1) with
  "EKF failsafe". MANUAL/ACRO/STEERING/HOLD are left alone.
* AP_BattMonitor::check_failsafes (10 Hz, armed): when a battery's failsafe rises (low, then
  critical) "Battery 1 is low 10.50V used 1234 mAh" (WARNING), then
  Rover::handle_battery_failsafe in the same call: BATT_FS_LOW_ACT / BATT_FS_CRT_ACT.
* Rover::fence_check (armed, enabled fence): no text; AC_Fence::record_breach has pushed
  FENCE_STATUS, then FENCE_ACTION.
  Both actions are Rover's FailsafeAction: 0 none, 1 RTL→HOLD, 2 HOLD, 3 SmartRTL→RTL→HOLD,
  4 SmartRTL→HOLD, 5 disarm, 6 (fence) Loiter→HOLD.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from helixd.mav.constants import MAV_SEVERITY_CRITICAL as SEVERITY_CRITICAL
from helixd.mav.constants import MAV_SEVERITY_INFO as SEVERITY_INFO
from helixd.mav.constants import MAV_SEVERITY_WARNING as SEVERITY_WARNING
from helixd.sim.firmware.estimator import SimEkfStatus
from helixd.sim.firmware.modes import HOLD as MODE_HOLD
from helixd.sim.firmware.modes import LOITER as MODE_LOITER
from helixd.sim.firmware.modes import RTL as MODE_RTL
from helixd.sim.firmware.modes import SMART_RTL as MODE_SMART_RTL
from helixd.sim.firmware.param_store import ParamStore

FAILSAFE_EVENT_THROTTLE = 1 << 0
FAILSAFE_EVENT_GCS = 1 << 1
EKF_CHECK_ITERATIONS_MAX = 10
FS_OPTION_ACTIVE_IN_HOLD = 1 << 0

FAILSAFE_ACTION_TERMINATE = 5
FAILSAFE_ACTION_LOITER_HOLD = 6


@dataclass(slots=True)
class FailsafeDecision:
    texts: list[tuple[int, str]] = field(default_factory=list)
    clear_overrides: bool = False
    modes_to_try: tuple[int, ...] = ()  # first one whose set_mode succeeds wins
    triggered: str | None = None  # the type_str of the call that fired (ArduPilot's text)
    causes: tuple[str, ...] = ()  # what is actually failing: "radio", "gcs", "ekf"
    cleared: str | None = None
    disarm: bool = False  # FailsafeAction::Terminate

    def merge(self, other: FailsafeDecision) -> None:
        self.texts.extend(other.texts)
        self.clear_overrides = self.clear_overrides or other.clear_overrides
        if other.modes_to_try:
            self.modes_to_try = other.modes_to_try
        self.triggered = other.triggered or self.triggered
        self.causes = other.causes or self.causes
        self.cleared = other.cleared or self.cleared
        self.disarm = self.disarm or other.disarm


def action_modes(fs_action: int) -> tuple[int, ...]:
    return {
        0: (),
        1: (MODE_RTL, MODE_HOLD),
        2: (MODE_HOLD,),
        3: (MODE_SMART_RTL, MODE_RTL, MODE_HOLD),
        4: (MODE_SMART_RTL, MODE_HOLD),
    }.get(fs_action, ())


def rover_action(action: int, decision: FailsafeDecision) -> FailsafeDecision:
    """Rover's FailsafeAction on ``decision`` (battery and fence)."""
    if action == FAILSAFE_ACTION_TERMINATE:
        decision.disarm = True
    elif action == FAILSAFE_ACTION_LOITER_HOLD:
        decision.modes_to_try = (MODE_LOITER, MODE_HOLD)
    else:
        decision.modes_to_try = action_modes(action)
    return decision


def battery_failsafe(
    voltage_v: float, used_mah: float, critical: bool, params: ParamStore
) -> FailsafeDecision:
    """Battery 1's failsafe fires (AP_BattMonitor::check_failsafes, then the action)."""
    kind = "critical" if critical else "low"
    text = f"Battery 1 is {kind} {voltage_v:.2f}V used {used_mah:.0f} mAh"
    decision = FailsafeDecision(
        texts=[(SEVERITY_WARNING, text)], triggered="Battery", causes=("battery",)
    )
    return rover_action(
        params.get_int("BATT_FS_CRT_ACT" if critical else "BATT_FS_LOW_ACT"), decision
    )


def fence_breach(params: ParamStore) -> FailsafeDecision:
    """A new breach of an enabled fence while armed (Rover::fence_check): no text."""
    decision = FailsafeDecision(triggered="Fence", causes=("fence",))
    return rover_action(params.get_int("FENCE_ACTION"), decision)


class Failsafes:
    def __init__(self) -> None:
        self.bits = 0
        self.triggered = 0
        self.start_time_s = 0.0
        self.last_valid_rc_s = 0.0
        self.ekf_fail_count = 0
        self.ekf_bad_variance = False
        self.ekf_failsafe = False

    def radio_on(self) -> bool:
        return bool(self.bits & FAILSAFE_EVENT_THROTTLE)

    def gcs_on(self) -> bool:
        return bool(self.bits & FAILSAFE_EVENT_GCS)

    def trigger(
        self, event: int, type_str: str, on: bool, now_s: float, mode: int, params: ParamStore
    ) -> FailsafeDecision:
        decision = FailsafeDecision()
        old_bits = self.bits
        self.bits = (self.bits | event) if on else (self.bits & ~event)
        if old_bits == 0 and self.bits != 0:
            self.start_time_s = now_s
        if self.triggered != 0 and self.bits == 0:
            # ArduPilot names the failsafe after the *calling* check, whichever fired: a GCS
            # failsafe is often reported as "Radio Failsafe" (the radio check runs at 50 Hz)
            decision.texts.append((SEVERITY_INFO, f"{type_str} Failsafe Cleared"))
            decision.cleared = type_str
        self.triggered &= self.bits
        in_hold_ok = mode != MODE_HOLD or (params.get_int("FS_OPTIONS") & FS_OPTION_ACTIVE_IN_HOLD)
        if (
            self.triggered == 0
            and self.bits != 0
            and now_s - self.start_time_s > params.get("FS_TIMEOUT")
            and mode != MODE_RTL
            and in_hold_ok
        ):
            self.triggered = self.bits
            decision.texts.append((SEVERITY_WARNING, f"{type_str} Failsafe"))
            decision.clear_overrides = True
            decision.modes_to_try = action_modes(params.get_int("FS_ACTION"))
            decision.triggered = type_str
            decision.causes = self.causes()
        return decision

    def causes(self) -> tuple[str, ...]:
        names = []
        if self.bits & FAILSAFE_EVENT_THROTTLE:
            names.append("radio")
        if self.bits & FAILSAFE_EVENT_GCS:
            names.append("gcs")
        return tuple(names)

    def radio_check(
        self, now_s: float, rc_read_ok: bool, throttle_pwm_us: int, mode: int, params: ParamStore
    ) -> FailsafeDecision:
        if rc_read_ok:
            self.last_valid_rc_s = now_s
        if not params.get_int("FS_THR_ENABLE"):
            return FailsafeDecision()
        failed = throttle_pwm_us < params.get_int("FS_THR_VALUE")
        if now_s - self.last_valid_rc_s > params.get("RC_FS_TIMEOUT"):
            failed = True
        return self.trigger(FAILSAFE_EVENT_THROTTLE, "Radio", failed, now_s, mode, params)

    def gcs_check(
        self, now_s: float, gcs_last_seen_s: float | None, mode: int, params: ParamStore
    ) -> FailsafeDecision:
        if not params.get_int("FS_GCS_ENABLE") or gcs_last_seen_s is None:
            return FailsafeDecision()
        failed = now_s - gcs_last_seen_s >= params.get("FS_GCS_TIMEOUT")
        return self.trigger(FAILSAFE_EVENT_GCS, "GCS", failed, now_s, mode, params)

    def ekf_check(
        self,
        armed: bool,
        health: SimEkfStatus,
        origin_set: bool,
        mode_requires_position: bool,
        params: ParamStore,
    ) -> FailsafeDecision:
        """ekf_check: what the EKF reports (its variances, whether it has a position) once the
        EKF origin is set."""
        decision = FailsafeDecision()
        thresh = params.get("FS_EKF_THRESH")
        if not origin_set:
            return decision
        if not armed or thresh <= 0.0:
            self.ekf_fail_count = 0
            self.ekf_bad_variance = False
            decision.merge(self._ekf_off())
            return decision
        if self._over_threshold(health, thresh):
            if not self.ekf_bad_variance:
                self.ekf_fail_count += 1
                if self.ekf_fail_count >= EKF_CHECK_ITERATIONS_MAX:
                    self.ekf_fail_count = EKF_CHECK_ITERATIONS_MAX
                    self.ekf_bad_variance = True
                    decision.texts.append((SEVERITY_CRITICAL, "EKF variance"))
                    decision.merge(self._ekf_event(mode_requires_position, params))
        elif self.ekf_fail_count > 0:
            self.ekf_fail_count -= 1
            if self.ekf_bad_variance and self.ekf_fail_count == 0:
                self.ekf_bad_variance = False
                decision.merge(self._ekf_off())
        return decision

    @staticmethod
    def _over_threshold(health: SimEkfStatus, thresh: float) -> bool:
        count = 0
        if health.compass_variance >= thresh:
            count += 1
        if health.velocity_variance >= thresh:
            count += 1
        if health.pos_horiz_variance >= thresh:
            count += 1
        # ekf_over_threshold then counts velocity again (+2 when ≥ 2× without optical flow),
        # so a bad velocity variance alone is enough — ported as is.
        if health.velocity_variance >= 2.0 * thresh:
            count += 2
        elif health.velocity_variance >= thresh:
            count += 1
        return count >= 2 or not health.position_ok

    def _ekf_event(self, mode_requires_position: bool, params: ParamStore) -> FailsafeDecision:
        decision = FailsafeDecision()
        if self.ekf_failsafe:
            return decision
        self.ekf_failsafe = True
        decision.triggered = "EKF"
        decision.causes = ("ekf",)
        action = params.get_int("FS_EKF_ACTION")
        if not mode_requires_position or action == 0:
            return decision
        if action != 2:  # 2 = report only
            decision.modes_to_try = (MODE_HOLD,)
        decision.texts.append((SEVERITY_CRITICAL, "EKF failsafe"))
        return decision

    def _ekf_off(self) -> FailsafeDecision:
        decision = FailsafeDecision()
        if self.ekf_failsafe:
            self.ekf_failsafe = False
            decision.texts.append((SEVERITY_CRITICAL, "EKF failsafe cleared"))
            decision.cleared = "EKF"
        return decision
