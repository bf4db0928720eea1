"""The EKF stand-in (helixd.sim.firmware.estimator)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from helixd.sim.firmware import estimator
from helixd.sim.firmware.estimator import EstimatorState
from helixd.sim.sim_config import NoiseProfile, SimConfig


def step_as_written_first(
    state: EstimatorState, dt_s: float, p: NoiseProfile, rng: np.random.Generator
) -> EstimatorState:
    """The step as it was first written (numpy scalars, dataclasses.replace): the reference."""
    z = rng.standard_normal(7)

    def gm(x: float, sigma: float, tau_s: float, zi: float) -> float:
        a = math.exp(-dt_s / tau_s)
        return a * x + sigma * math.sqrt(max(0.0, 1.0 - a * a)) * zi

    dn = gm(state.drift_n_m, p.pos_sigma_m, p.pos_tau_s, z[0])
    de = gm(state.drift_e_m, p.pos_sigma_m, p.pos_tau_s, z[1])
    dyaw = gm(state.drift_yaw_rad, p.yaw_sigma_rad, p.yaw_tau_s, z[2])
    fix_n = dn + p.pos_white_m * z[3] + state.jump_n_m
    fix_e = de + p.pos_white_m * z[4] + state.jump_e_m
    alpha = 1.0 - math.exp(-dt_s / p.ekf_tau_s)
    return dataclasses.replace(
        state,
        drift_n_m=dn,
        drift_e_m=de,
        drift_yaw_rad=dyaw,
        fix_n_m=fix_n,
        fix_e_m=fix_e,
        err_n_m=state.err_n_m + (fix_n - state.err_n_m) * alpha,
        err_e_m=state.err_e_m + (fix_e - state.err_e_m) * alpha,
        err_yaw_rad=state.err_yaw_rad + (dyaw - state.err_yaw_rad) * alpha,
        vel_err_n_mps=p.vel_white_mps * z[5],
        vel_err_e_mps=p.vel_white_mps * z[6],
        pos_variance_boost=state.pos_variance_boost
        * math.exp(-dt_s / estimator.JUMP_VARIANCE_DECAY_S),
    )


def test_a_step_gives_the_very_same_doubles_as_the_step_first_written() -> None:
    """Every field carried or updated, to the bit, for each noise profile, after a GPS jump
    too: the simulator's seeded days stay the days they were."""
    profiles = SimConfig().noise_profiles
    for name in ("none", "low", "thesis"):
        profile = getattr(profiles, name)
        ours, ref = np.random.default_rng(7), np.random.default_rng(7)
        state = estimator.gps_jump(EstimatorState(), 2.0, 0.7, 0.9)
        expected = state
        for _ in range(200):
            state = estimator.step(state, 0.02, profile, ours)
            expected = step_as_written_first(expected, 0.02, profile, ref)
            assert dataclasses.astuple(state) == dataclasses.astuple(expected)
        assert state.jump_n_m == 2.0 * math.cos(0.7)
