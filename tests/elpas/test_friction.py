"""LuGre friction: steady state (Stribeck curve) and presliding stiffness, in isolation and in the drive."""

import numpy as np
import pytest

from vsa_gym.devices.elpas import model as em
from vsa_gym.devices.elpas.params import ConeGeometry, ElpasParams
from vsa_gym.physics import friction as fr

P = ElpasParams()
LG = P.friction


def _formula(w: np.ndarray) -> np.ndarray:
    return (LG.F_c + (LG.F_s - LG.F_c) * np.exp(-((w / LG.omega_s) ** 2))) * np.sign(w) + LG.s2 * w


def test_bristle_ode_settles_on_the_stribeck_curve() -> None:
    w = np.array([-400.0, -30.0, -5.0, 2.0, 11.8, 60.0, 400.0])

    def rhs(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        zd = fr.bristle_derivative(LG, w, x[:, 0])
        return zd[:, None], fr.lugre_moment(LG, w, x[:, 0], zd)[:, None] * w[:, None]

    x = np.zeros((w.size, 1))
    for _ in range(400):  # 0.4 s: >= 20 time constants (rate >= 54 1/s)
        x, _ = fr.exponential_rk4(rhs, x, 1e-3, 1, (0,),
                                  lambda xx: fr.bristle_rate(LG, w)[:, None])
    zd = fr.bristle_derivative(LG, w, x[:, 0])
    np.testing.assert_allclose(fr.lugre_moment(LG, w, x[:, 0], zd), _formula(w), rtol=1e-6)
    np.testing.assert_allclose(fr.steady_state_moment(LG, w), _formula(w), rtol=1e-12)


def test_drive_steady_state_friction_at_constant_voltage() -> None:
    # rod disconnected (no spring), as in the paper's Fig. 13 (left) experiment
    p = P.replace(cone=ConeGeometry(F_s0=0.0, C_a=0.0))
    u = np.array([-30.0, -8.0, -2.0, 2.0, 8.0, 30.0])
    gamma0 = np.sign(u) * np.radians(85.0)  # omega_m = N dgamma/dt with N < 0: run away from the stop
    x = em.initial_state_rig(p, u.size, gamma=gamma0)
    inputs = np.stack([u, np.zeros_like(u)], axis=1)
    for _ in range(150):
        x, _ = em.step_rig(p, x, inputs)
    w_m = em.motor_speed(p, x)
    assert np.all(np.abs(x[:, em.GAMMA]) < p.cone.gamma_max)
    torque = p.motor.k_t * x[:, em.CURRENT]
    np.testing.assert_allclose(torque, _formula(w_m), rtol=1e-4)
    np.testing.assert_allclose(em.friction_moment(p, x), _formula(w_m), rtol=1e-4)


def test_presliding_stiffness_below_coulomb_is_s0() -> None:
    p = P  # rods connected at alpha = 0: the spring exerts no moment on the arm
    n_steps = 400
    m_ref = 0.05 * np.arange(1, n_steps + 1) / n_steps  # ramp to 0.05 N m, below F_c = 0.2 N m
    x = em.initial_state_rig(p, 1)
    theta, moment = [], []
    for k in range(n_steps):
        i_ref = m_ref[k] / p.motor.k_t
        u = p.motor.R * i_ref + p.motor.k_e * em.motor_speed(p, x)[0]
        x, _ = em.step_rig(p, x, np.array([[u, 0.0]]))
        theta.append(p.drive.N * x[0, em.GAMMA])
        moment.append(p.motor.k_t * x[0, em.CURRENT])
    theta_a, moment_a = np.array(theta), np.array(moment)
    stiffness = np.polyfit(theta_a[50:], moment_a[50:], 1)[0]
    assert stiffness == pytest.approx(LG.s0, rel=0.1)
    assert np.max(np.abs(theta_a)) < LG.F_c / LG.s0  # no gross sliding
