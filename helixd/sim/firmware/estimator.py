"""GPS + EKF model (pure; the caller passes the random generator).

The error is what matters to helixd: a slow Gauss–Markov drift (GPS without RTK wanders by
about a metre, thesis ch. 5.2) plus white jitter per fix, smoothed by a first-order 'EKF'
filter. The filter works on the *error* only, so the estimate follows true motion without lag
(as an EKF with a good IMU does). Faults: a GPS jump shifts every later fix by a fixed offset;
'ekf_unhealthy' raises the innovation test ratios above FS_EKF_THRESH and drops the position
flags. EKF_STATUS_REPORT flags are ArduPilot's EKF_STATUS_FLAGS.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from helixd.base.angles import wrap_pi
from helixd.mav.constants import (
    EKF_ATTITUDE,
    EKF_CONST_POS_MODE,
    EKF_POS_HORIZ_ABS,
    EKF_POS_HORIZ_REL,
    EKF_POS_VERT_ABS,
    EKF_PRED_POS_HORIZ_ABS,
    EKF_PRED_POS_HORIZ_REL,
    EKF_UNINITIALIZED,
    EKF_VELOCITY_HORIZ,
    EKF_VELOCITY_VERT,
)
from helixd.mav.ekf_report import EkfReport
from helixd.plant.state import PhysicsState
from helixd.sim.sim_config import NoiseProfile

HEALTHY_FLAGS = (
    EKF_ATTITUDE
    | EKF_VELOCITY_HORIZ
    | EKF_VELOCITY_VERT
    | EKF_POS_HORIZ_REL
    | EKF_POS_HORIZ_ABS
    | EKF_POS_VERT_ABS
    | EKF_PRED_POS_HORIZ_REL
    | EKF_PRED_POS_HORIZ_ABS
)
UNHEALTHY_FLAGS = EKF_ATTITUDE | EKF_VELOCITY_VERT | EKF_CONST_POS_MODE
UNHEALTHY_VARIANCE = 1.2  # > FS_EKF_THRESH default 0.8 on every axis
JUMP_VARIANCE = 1.0
JUMP_VARIANCE_DECAY_S = 5.0


@dataclass(frozen=True, slots=True)
class EstimatorState:
    drift_n_m: float = 0.0  # Gauss–Markov GPS error
    drift_e_m: float = 0.0
    drift_yaw_rad: float = 0.0
    fix_n_m: float = 0.0  # last raw fix error (drift + jitter + jump), for GPS_RAW_INT
    fix_e_m: float = 0.0
    err_n_m: float = 0.0  # smoothed error of the EKF output
    err_e_m: float = 0.0
    err_yaw_rad: float = 0.0
    vel_err_n_mps: float = 0.0
    vel_err_e_mps: float = 0.0
    jump_n_m: float = 0.0  # persistent GPS offset after a jump
    jump_e_m: float = 0.0
    pos_variance_boost: float = 0.0


@dataclass(frozen=True, slots=True)
class PoseEstimate:
    north_m: float
    east_m: float
    yaw_ned_rad: float
    v_north_mps: float
    v_east_mps: float
    yaw_rate_ned_radps: float


@dataclass(frozen=True, slots=True)
class SimEkfStatus(EkfReport):
    @property
    def position_ok(self) -> bool:
        return bool(self.flags & (EKF_POS_HORIZ_ABS | EKF_POS_HORIZ_REL)) and not bool(
            self.flags & EKF_CONST_POS_MODE
        )


def _gauss_markov(x: float, sigma: float, tau_s: float, dt_s: float, z: float) -> float:
    a = math.exp(-dt_s / tau_s)
    return a * x + sigma * math.sqrt(max(0.0, 1.0 - a * a)) * z


def step(
    state: EstimatorState, dt_s: float, profile: NoiseProfile, rng: np.random.Generator
) -> EstimatorState:
    # as Python floats: the same doubles, without numpy's scalar arithmetic in every loop
    z: list[float] = rng.standard_normal(7).tolist()
    dn = _gauss_markov(state.drift_n_m, profile.pos_sigma_m, profile.pos_tau_s, dt_s, z[0])
    de = _gauss_markov(state.drift_e_m, profile.pos_sigma_m, profile.pos_tau_s, dt_s, z[1])
    dyaw = _gauss_markov(state.drift_yaw_rad, profile.yaw_sigma_rad, profile.yaw_tau_s, dt_s, z[2])
    fix_n = dn + profile.pos_white_m * z[3] + state.jump_n_m
    fix_e = de + profile.pos_white_m * z[4] + state.jump_e_m
    alpha = 1.0 - math.exp(-dt_s / profile.ekf_tau_s)
    boost = state.pos_variance_boost * math.exp(-dt_s / JUMP_VARIANCE_DECAY_S)
    return EstimatorState(  # every field (no dataclasses.replace: it costs as much as the rest)
        drift_n_m=dn,
        drift_e_m=de,
        drift_yaw_rad=dyaw,
        fix_n_m=fix_n,
        fix_e_m=fix_e,
        err_n_m=state.err_n_m + (fix_n - state.err_n_m) * alpha,
        err_e_m=state.err_e_m + (fix_e - state.err_e_m) * alpha,
        err_yaw_rad=state.err_yaw_rad + (dyaw - state.err_yaw_rad) * alpha,
        vel_err_n_mps=profile.vel_white_mps * z[5],
        vel_err_e_mps=profile.vel_white_mps * z[6],
        jump_n_m=state.jump_n_m,
        jump_e_m=state.jump_e_m,
        pos_variance_boost=boost,
    )


def gps_jump(
    state: EstimatorState,
    distance_m: float,
    bearing_rad: float,
    variance: float = JUMP_VARIANCE,
) -> EstimatorState:
    """Every later fix is off by ``distance_m`` towards ``bearing_rad`` (clockwise from N).

    The EKF output follows within its smoothing time (ArduPilot's EKF3 resets its position to
    a persistently jumped GPS after its glitch timeout; modelled as an immediate step), its
    horizontal position variance raised by ``variance`` (decaying over
    ``JUMP_VARIANCE_DECAY_S``; 0: a jump the EKF took without complaint).
    """
    jn = state.jump_n_m + distance_m * math.cos(bearing_rad)
    je = state.jump_e_m + distance_m * math.sin(bearing_rad)
    return replace(
        state,
        jump_n_m=jn,
        jump_e_m=je,
        err_n_m=state.err_n_m + distance_m * math.cos(bearing_rad),
        err_e_m=state.err_e_m + distance_m * math.sin(bearing_rad),
        pos_variance_boost=variance,
    )


def estimate(state: EstimatorState, truth: PhysicsState) -> PoseEstimate:
    return PoseEstimate(
        north_m=truth.north_m + state.err_n_m,
        east_m=truth.east_m + state.err_e_m,
        yaw_ned_rad=wrap_pi(truth.yaw_ned_rad + state.err_yaw_rad),
        v_north_mps=truth.v_north_mps + state.vel_err_n_mps,
        v_east_mps=truth.v_east_mps + state.vel_err_e_mps,
        yaw_rate_ned_radps=truth.yaw_rate_ned_radps,
    )


def gps_fix(state: EstimatorState, truth: PhysicsState) -> tuple[float, float]:
    """Raw GPS position (north_m, east_m) from the origin."""
    return truth.north_m + state.fix_n_m, truth.east_m + state.fix_e_m


def ekf_status(
    state: EstimatorState, profile: NoiseProfile, origin_set: bool, unhealthy: bool
) -> SimEkfStatus:
    if not origin_set:
        return SimEkfStatus(EKF_ATTITUDE | EKF_UNINITIALIZED, 0.0, 0.0, 0.0, 0.0, 0.0)
    if unhealthy:
        v = UNHEALTHY_VARIANCE
        return SimEkfStatus(UNHEALTHY_FLAGS, v, v, v, v, 0.0)
    base = profile.variance_base
    return SimEkfStatus(
        HEALTHY_FLAGS,
        velocity_variance=base * 0.5,
        pos_horiz_variance=min(1.5, base + state.pos_variance_boost),
        pos_vert_variance=base * 0.5,
        compass_variance=base * 0.5,
        terrain_alt_variance=0.0,
    )
