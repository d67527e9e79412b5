"""The vsaUT-II equations of motion at one point (scalars or columns) and on one row: the single source of the
right-hand side that the numpy path, the compiled row kernels (:mod:`vsa_gym.devices.vsaut2.kernels`) and the energy
balance use (:mod:`vsa_gym.devices.vsaut2.model` documents the model)."""

from __future__ import annotations

from typing import Any

import numpy as np
from numba.extending import register_jitable

from vsa_gym.devices.vsaut2.belt import belt_force
from vsa_gym.devices.vsaut2.layout import N_POWER, N_STATES, STOP_EPS_FRAME, STOP_EPS_MOTOR, STOP_MARGIN_MOTOR, Derived
from vsa_gym.devices.vsaut2.lever import lever_forces
from vsa_gym.devices.vsaut2.params import VsaUT2Params
from vsa_gym.devices.vsaut2.pivot import pivot_jacobian, pivot_position
from vsa_gym.physics.contact import two_sided_stop
from vsa_gym.physics.dc_motor import applied_voltage, current_derivative, shaft_torque
from vsa_gym.physics.gearbox import input_torque
from vsa_gym.physics.kernels import scalar_shortcut, select


def dead_zone_energy(x: np.ndarray, eps: float | np.ndarray) -> np.ndarray:
    """Antiderivative of ``sqrt(x^2 + eps^2)``: the backlash term of the belt's stored energy."""
    return 0.5 * (x * np.sqrt(x**2 + eps**2) + eps**2 * np.arcsinh(x / eps))


@register_jitable
def rhs_point(
    p: VsaUT2Params, d: Derived, i1: Any, th1: Any, w1: Any, i2: Any, th2: Any, w2: Any, q2: Any, q2d: Any,
    r: Any, rd: Any, hz: Any, u_1: Any, u_2: Any, tau_ext: Any, pt0: Any, pt1: Any, pt2: Any, pt3: Any, pt4: Any,
    pt5: Any, pt6: Any,
) -> tuple[tuple[Any, ...], tuple[Any, ...]]:
    """The vsaUT-II equations of motion (module docstring), written once, element-wise.

    Every state, input and port argument is either an ``(n,)`` column (numpy path, ``p`` a
    :class:`VsaUT2Params`) or a float (compiled per-row path, ``p`` one row of the parameter
    tuple, see :func:`vsa_gym.physics.kernels.row_of`).  ``hz`` is the spring hysteresis state
    (``EFFECT_STATE["h_phi"]``; ``0.0`` where the layout has no such column).  ``pt0..pt6`` are the
    additive extension forces in :data:`PORTS` order.  Returns the 10 state derivatives plus ``dhz/dt``
    (11 entries) and the 7 power channels.
    """
    m1, m2, g1, g2 = p.pivot_motor, p.frame_motor, p.pivot_gearbox, p.frame_gearbox

    # kinematics
    th_s = th1 / g1.n
    jac = pivot_jacobian(p.pivot, th_s)
    q1 = pivot_position(p.pivot, th_s)
    q1_dot = jac * w1 / g1.n
    delta = d.r_ip * th2 / g2.n - p.belt.r_op * q2

    # identified effects (VsaUT2Effects; all zero by default, then every term below is exactly 0.0):
    # backlash as a smooth dead zone on the belt stretch, Coulomb + Stribeck friction at the joints
    # (the compiled per-row path skips an absent effect's transcendentals: scalar_shortcut gives the same bits)
    e = p.effects
    if scalar_shortcut(e.b_belt == 0.0):
        delta_bl = delta  # the two square roots below are then equal: delta - 0.0
    else:
        delta_bl = delta - 0.5 * (np.sqrt((delta + e.b_belt) ** 2 + e.b_eps**2)
                                  - np.sqrt((delta - e.b_belt) ** 2 + e.b_eps**2))
    if scalar_shortcut((e.F_c_o == 0.0) & (e.F_s_o == 0.0)):
        tau_fo = 0.0 * rd  # 0.0 * tanh(rd / w_eps): a zero with the sign of rd
    else:
        tau_fo = (e.F_c_o + e.F_s_o * np.exp(-((rd / e.w_s_o) ** 2))) * np.tanh(rd / e.w_eps)
    tau_fad = 0.0 * q2d if scalar_shortcut(e.F_c_ad == 0.0) else e.F_c_ad * np.tanh(q2d / e.w_eps)
    # elastic elements (+ extension ports)
    phi_dot = rd - q2d
    lev = lever_forces(p.lever, q1, r - q2, q1_dot, phi_dot)

    # spring hysteresis (Dahl) along phi: torque -hz on the output, dhz/dt = (M phi_dot - |phi_dot| hz) / phi_h with
    # the loop half-height M = M_h + mu_h |tau_s| (mu_h: load-proportional part, tau_s the lever spring torque);
    # stores hz^2 phi_h / (2 M), dissipates |phi_dot| hz^2 / M.  M_h = mu_h = 0: absent (whatever hz), and the terms
    # below are exactly 0.0 (tau_phi - 0.0 and viscous + 0.0 keep their bits); mu_h = 0: M = M_h + 0.0, same bits
    if scalar_shortcut((e.M_h == 0.0) & (e.mu_h == 0.0)):
        tau_h, dhz, p_h = 0.0, 0.0, 0.0
    else:
        on = (e.M_h > 0.0) | (e.mu_h > 0.0)
        m_h = e.M_h + e.mu_h * np.abs(lev.tau_phi)
        a_h = np.abs(phi_dot) * hz
        tau_h = select(on, hz, 0.0)
        dhz = select(on, (m_h * phi_dot - a_h) / e.phi_h, 0.0)
        p_h = select(on, a_h * hz / select(on & (m_h > 0.0), m_h, 1.0), 0.0)

    F_b = belt_force(p.belt, delta_bl) + pt0
    tau_phi = lev.tau_phi + pt1 - tau_h
    F_q1 = lev.F_q1 + pt2

    # motors: amplifier limits, circuits
    u1 = applied_voltage(m1, u_1, i1, w1)
    u2 = applied_voltage(m2, u_2, i2, w2)

    # gearboxes: pivot force seen at the GP26B output, belt load at the GP42C output
    tau_in1, p_gb1 = input_torque(g1, -F_q1 * jac, w1)
    tau_in2, p_gb2 = input_torque(g2, d.r_ip * F_b, w2)

    # pivot stroke stop on the motor shaft (th1 in [0, th1_max]) and frame end stops
    stop1 = two_sided_stop(th1, w1, -STOP_MARGIN_MOTOR, d.th1_max + STOP_MARGIN_MOTOR, p.K_s1, p.D_s1, STOP_EPS_MOTOR)
    stop2 = two_sided_stop(q2, q2d, -p.q2_max, p.q2_max, p.K_q2, p.D_q2, STOP_EPS_FRAME)

    dx = (
        current_derivative(m1, u1, i1, w1),
        w1,
        (shaft_torque(m1, i1, w1) - tau_in1 + stop1.force + pt3) / d.J1,
        current_derivative(m2, u2, i2, w2),
        w2,
        (shaft_torque(m2, i2, w2) - tau_in2 + pt4) / d.J2,
        q2d,
        (p.belt.r_op * F_b - tau_phi - p.c_ad * q2d - tau_fad + stop2.force + pt5) / p.I_ad,
        rd,
        (tau_phi - p.c_o * rd - tau_fo + tau_ext + pt6) / p.I_o,
        dhz,
    )
    pw = (
        u1 * i1,
        u2 * i2,
        tau_ext * rd,
        m1.R * i1**2 + m2.R * i2**2,
        m1.b * w1**2 + m2.b * w2**2 + p.c_ad * q2d**2 + p.c_o * rd**2 + tau_fad * q2d + tau_fo * rd + p_h,
        p_gb1 + p_gb2,
        lev.p_diss + stop1.p_diss + stop2.p_diss,
    )
    return dx, pw


def rhs_core(
    x: np.ndarray, u: np.ndarray, tau_ext: np.ndarray, p: VsaUT2Params, d: Derived, ports: np.ndarray,
    dx: np.ndarray, pw: np.ndarray, n_effect: int = 0,
) -> None:
    """:func:`rhs_point` on columns (numpy path). ``x``: ``(n, >= 10 + n_effect)``; ``ports``: ``(n, 7)``;
    ``n_effect``: the effect-state columns after the 10 core states (0, or 1: the hysteresis state).

    Fills ``dx`` (first ``10 + n_effect`` columns) and ``pw`` ``(n, 7)`` in place.
    """
    hz = x[:, N_STATES] if n_effect else 0.0 * x[:, 0]
    dxs, pws = rhs_point(p, d, x[:, 0], x[:, 1], x[:, 2], x[:, 3], x[:, 4], x[:, 5], x[:, 6], x[:, 7], x[:, 8],
                          x[:, 9], hz, u[:, 0], u[:, 1], tau_ext, ports[:, 0], ports[:, 1], ports[:, 2],
                          ports[:, 3], ports[:, 4], ports[:, 5], ports[:, 6])
    for k in range(N_STATES + n_effect):
        dx[:, k] = dxs[k]
    for k in range(N_POWER):
        pw[:, k] = pws[k]


@register_jitable(inline="always")  # inlined into the RK4/ETD stage loops: ~10 % per RHS, same bits
def rhs_row(p: Any, d: Any, y: np.ndarray, u_1: float, u_2: float, tau: float, dx: np.ndarray,
             pw: np.ndarray) -> None:
    """:func:`rhs_point` on one row (floats), no extensions; fills the row vectors ``dx`` and ``pw``.

    A row of 11 entries carries the hysteresis state (``EFFECT_STATE["h_phi"]``); one of 10 is the nominal
    layout (the state ``hz`` is then ``0.0``, and with ``M_h = 0`` the effect is skipped).
    """
    has_h = y.shape[0] > N_STATES
    hz = y[N_STATES] if has_h else 0.0
    dxs, pws = rhs_point(p, d, y[0], y[1], y[2], y[3], y[4], y[5], y[6], y[7], y[8], y[9], hz, u_1, u_2, tau,
                          0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    for k in range(N_STATES):
        dx[k] = dxs[k]
    if has_h:
        dx[N_STATES] = dxs[N_STATES]
    for k in range(N_POWER):
        pw[k] = pws[k]
