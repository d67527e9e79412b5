"""The eLPAS equations (drive, rig, quarter car), written once as point functions.

The equations are those of :mod:`vsa_gym.devices.elpas.model` (its docstring states them).  The point functions take
scalars (one row, inside the compiled per-row integrator, :mod:`vsa_gym.devices.elpas.integrator`) or ``(n,)`` columns
(the numpy right-hand sides :func:`rhs_rig` / :func:`rhs_vehicle` and the observables); both forms run the same
operations in the same order.  ``p`` is an :class:`~vsa_gym.devices.elpas.params.ElpasParams` (floats or ``(n,)``
arrays) or, compiled, a row of :mod:`vsa_gym.devices.elpas.packing`.

:func:`rhs_q_row` is the right-hand side of one row in the integrator's ``(q, z)`` variables
(``q = J_r omega + N s1 z``, see :func:`omega_of_q`).
"""

from __future__ import annotations

import numpy as np
from numba.extending import register_jitable

from vsa_gym.devices.elpas.cone import spring_unchecked
from vsa_gym.devices.elpas.extensions import ExtensionContext
from vsa_gym.devices.elpas.layout import (
    ALPHA,
    ALPHA_DOT,
    BRISTLE,
    CURRENT,
    GAMMA,
    IN_ALPHA,
    IN_ROAD,
    IN_VOLTAGE,
    N_PORTS,
    N_POWER,
    N_RIG,
    N_VEHICLE,
    OMEGA,
    P_DAMPER,
    P_EL,
    P_EXT,
    P_FRIC,
    P_OUT,
    P_RES,
    P_STOP,
    V_S,
    Y_R,
    Y_S,
    Extensions,
    effect_column,
    effect_state_columns,
)
from vsa_gym.devices.elpas.params import GRAVITY, ElpasParams
from vsa_gym.physics.dc_motor import applied_voltage, current_derivative, shaft_torque
from vsa_gym.physics.friction import bristle_derivative, lugre_moment
from vsa_gym.physics.kernels import select


# ----------------------------------------------------------------------------- point equations
@register_jitable
def end_stop(q: np.ndarray, qd: np.ndarray, q_max: np.ndarray | float, k: np.ndarray | float,
              d: np.ndarray | float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Hunt-Crossley end stops at ``+-q_max``: (moment, dissipated power, stored energy)."""
    over = q - q_max
    under = -q_max - q
    sgn = (over > 0.0) * 1.0 - (under > 0.0) * 1.0
    pen = np.maximum(over, 0.0) + np.maximum(under, 0.0)
    pen_rate = sgn * qd
    contact = np.maximum(k * pen * (1.0 + d * pen_rate), 0.0)
    moment = -sgn * contact
    dissipated = contact * pen_rate - k * pen * pen_rate
    return moment, dissipated, 0.5 * k * pen**2


@register_jitable
def _stop_terms(q: np.ndarray, qd: np.ndarray, q_max: np.ndarray | float, k: np.ndarray | float,
                d: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
    """End-stop moment and dissipation of columns, skipping the work when no row is in contact."""
    moment = np.zeros_like(q)
    dissipated = np.zeros_like(q)
    if np.any(np.abs(q) > q_max):
        moment, dissipated, _ = end_stop(q, qd, q_max, k, d)
    return moment, dissipated


@register_jitable
def stop_point(q: float, qd: float, q_max: float, k: float, d: float) -> tuple[float, float]:
    """:func:`_stop_terms` at one point (scalars; the same :func:`end_stop` in contact, else zero)."""
    if abs(q) > q_max:
        moment, dissipated, _ = end_stop(q, qd, q_max, k, d)
        return moment, dissipated
    return 0.0, 0.0


@register_jitable
def arm_hysteresis(e: ElpasParams, omega: np.ndarray, hz: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Arm hysteresis (Dahl, :class:`~vsa_gym.devices.elpas.params.ElpasEffects`) of state ``hz`` at arm speed
    ``omega``: ``(moment h taken off the arm, dh/dt, dissipated power)``, each 0 where ``M_h = 0``.

    ``e``: ``p.effects``; scalars (one compiled row) or ``(n,)`` columns.
    """
    on = e.M_h > 0.0
    a_h = np.abs(omega) * hz
    return (select(on, hz, 0.0), select(on, (e.M_h * omega - a_h) / e.phi_h, 0.0),
            select(on, a_h * hz / select(on, e.M_h, 1.0), 0.0))


@register_jitable
def actuator_terms(gamma: np.ndarray, omega: np.ndarray, i: np.ndarray, z: np.ndarray, alpha: np.ndarray,
                    u: np.ndarray, alpha_dot: np.ndarray, p: ElpasParams, tau_ext: np.ndarray, f_ext: np.ndarray,
                    stop_M: np.ndarray, tau_h: np.ndarray | float) -> tuple[np.ndarray, ...]:
    """Drive equations (module docstring) given the end-stop moment ``stop_M`` and the arm hysteresis moment
    ``tau_h`` (:func:`arm_hysteresis`; taken off the arm, ``0.0`` without it).

    Returns ``(domega/dt, di/dt, dz/dt, P_EL, P_RES, P_FRIC, P_EXT, F_apart)`` with
    ``F_apart = F_act + port force``.
    """
    m, fr, dr, c = p.motor, p.friction, p.drive, p.cone
    w_m = dr.N * omega
    u_eff = applied_voltage(m, u, i, w_m)
    zdot = bristle_derivative(fr, w_m, z)
    M_fric = lugre_moment(fr, w_m, z, zdot)
    sp = spring_unchecked(c, gamma, alpha)
    x_ext_rate = -c.l * np.cos(alpha) * alpha_dot
    d_omega = (dr.N * (shaft_torque(m, i, w_m) - M_fric) + sp.T_gamma + stop_M + tau_ext - tau_h) / dr.J_r
    d_i = current_derivative(m, u_eff, i, w_m)
    return (d_omega, d_i, zdot, u_eff * i, m.R * i**2, (M_fric + m.b * w_m) * w_m,
            -(tau_ext * omega + f_ext * x_ext_rate), sp.F_act + f_ext)


@register_jitable
def _actuator_core(x: np.ndarray, u: np.ndarray, alpha_dot: np.ndarray, p: ElpasParams, ports: np.ndarray,
                   dx: np.ndarray, pw: np.ndarray, h_col: int) -> np.ndarray:
    """Drive equations on columns: fills ``dx[:, :N_RIG]`` (alpha column excepted), the arm hysteresis state's
    derivative in column ``h_col`` (``-1``: no such column) and all power channels but ``P_DAMPER``/``P_OUT`` (set
    to 0); returns ``F_apart = F_act + port force``."""
    dr, c = p.drive, p.cone
    gamma, omega = x[:, GAMMA], x[:, OMEGA]
    stop_M, stop_diss = _stop_terms(gamma, omega, c.gamma_max, dr.k_stop, dr.d_stop)
    tau_h, p_h = 0.0, 0.0
    if h_col >= 0:
        tau_h, dx[:, h_col], p_h = arm_hysteresis(p.effects, omega, x[:, h_col])
    d_omega, d_i, zdot, p_el, p_res, p_fric, p_ext, F_apart = actuator_terms(
        gamma, omega, x[:, CURRENT], x[:, BRISTLE], x[:, ALPHA], u, alpha_dot, p, ports[:, 0], ports[:, 1], stop_M,
        tau_h)
    dx[:, GAMMA] = omega
    dx[:, OMEGA] = d_omega
    dx[:, CURRENT] = d_i
    dx[:, BRISTLE] = zdot
    pw[:, P_EL] = p_el
    pw[:, P_RES] = p_res
    pw[:, P_FRIC] = p_fric + p_h if h_col >= 0 else p_fric
    pw[:, P_STOP] = stop_diss
    pw[:, P_DAMPER] = 0.0
    pw[:, P_EXT] = p_ext
    pw[:, P_OUT] = 0.0
    return F_apart


@register_jitable
def rig_power_out(F_apart: np.ndarray, alpha: np.ndarray, alpha_dot: np.ndarray, p: ElpasParams) -> np.ndarray:
    """Rig: power into the hydropulse, ``F_apart dx_ext/dt``."""
    return F_apart * (-p.cone.l * np.cos(alpha) * alpha_dot)


@register_jitable
def _rhs_rig_core(x: np.ndarray, rin: np.ndarray, p: ElpasParams, ports: np.ndarray, dx: np.ndarray,
                  pw: np.ndarray, h_col: int) -> None:
    """Rig right-hand side into ``dx[:, :N_RIG]`` (and the hysteresis column ``h_col``, ``-1``: none) and ``pw``;
    ``rin``: voltage, dalpha/dt."""
    alpha_dot = rin[:, IN_ALPHA]
    F_apart = _actuator_core(x, rin[:, IN_VOLTAGE], alpha_dot, p, ports, dx, pw, h_col)
    dx[:, ALPHA] = alpha_dot
    pw[:, P_OUT] = rig_power_out(F_apart, x[:, ALPHA], alpha_dot, p)


@register_jitable
def tyre_force_point(y_s: np.ndarray, alpha: np.ndarray, y_r: np.ndarray, p: ElpasParams) -> np.ndarray:
    """Tyre force ``k_t max(y_r - y_u + delta_0, 0)`` (N) from body height, wishbone angle and road height."""
    car = p.car
    y_u = y_s + p.cone.l * np.sin(alpha)
    delta0 = (car.m_s + car.m_u) * GRAVITY / car.k_t
    return car.k_t * np.maximum(y_r - y_u + delta0, 0.0)


@register_jitable
def _tyre_force_core(x: np.ndarray, p: ElpasParams) -> np.ndarray:
    """:func:`tyre_force_point` of state columns."""
    return tyre_force_point(x[:, Y_S], x[:, ALPHA], x[:, Y_R], p)


@register_jitable
def vehicle_terms(alpha: np.ndarray, alpha_dot: np.ndarray, F_apart: np.ndarray, F_t: np.ndarray,
                   bump_M: np.ndarray, road_rate: np.ndarray, p: ElpasParams) -> tuple[np.ndarray, ...]:
    """Quarter-car equations (module docstring). Returns ``(dalpha_dot/dt, dv_s/dt, P_DAMPER, P_OUT)``."""
    car, l = p.car, p.cone.l
    ca, sa = np.cos(alpha), np.sin(alpha)
    travel_rate = l * ca * alpha_dot  # d(l sin alpha)/dt, compression rate
    F_damp = car.c_p * travel_rate
    m_tot = car.m_s + car.m_u
    Q_y = F_t - m_tot * GRAVITY + car.m_u * l * sa * alpha_dot**2
    Q_a = l * ca * (F_t - car.m_u * GRAVITY - F_apart - F_damp) + bump_M + car.m_u * l**2 * ca * sa * alpha_dot**2
    M12 = car.m_u * l * ca
    M22 = car.m_u * (l * ca) ** 2 + car.J_w
    det = m_tot * M22 - M12**2
    return (m_tot * Q_a - M12 * Q_y) / det, (M22 * Q_y - M12 * Q_a) / det, F_damp * travel_rate, -F_t * road_rate


@register_jitable
def _rhs_vehicle_core(x: np.ndarray, rin: np.ndarray, p: ElpasParams, ports: np.ndarray, dx: np.ndarray,
                      pw: np.ndarray, h_col: int) -> None:
    """Quarter-car right-hand side into ``dx[:, :N_VEHICLE]`` (and the hysteresis column ``h_col``) and ``pw``;
    ``rin``: voltage, dy_r/dt."""
    car = p.car
    alpha, alpha_dot = x[:, ALPHA], x[:, ALPHA_DOT]
    F_apart = _actuator_core(x, rin[:, IN_VOLTAGE], alpha_dot, p, ports, dx, pw, h_col)
    F_t = _tyre_force_core(x, p)
    bump_M, bump_diss = _stop_terms(alpha, alpha_dot, p.cone.alpha_max, car.k_bump, car.d_bump)
    d_ad, d_vs, p_damp, p_out = vehicle_terms(alpha, alpha_dot, F_apart, F_t, bump_M, rin[:, IN_ROAD], p)
    dx[:, ALPHA] = alpha_dot
    dx[:, ALPHA_DOT] = d_ad
    dx[:, Y_S] = x[:, V_S]
    dx[:, V_S] = d_vs
    dx[:, Y_R] = rin[:, IN_ROAD]
    pw[:, P_DAMPER] = p_damp
    pw[:, P_STOP] += bump_diss
    pw[:, P_OUT] = p_out


# ----------------------------------------------------------------------------- the integrator's (q, z) variables
# The bristle damping ``s1 dz/dt`` couples the stiff bristle mode into the speed: along that mode
# ``q = J_r omega + N s1 z`` stays constant, so the integrator carries ``q`` in the OMEGA column.
@register_jitable
def q_constants(p: ElpasParams) -> tuple[np.ndarray, np.ndarray]:
    """``(c, J)`` of the change of variables ``q = J omega + c z``: ``c = N s1``, ``J = J_r``."""
    return p.drive.N * p.friction.s1, p.drive.J_r


@register_jitable
def q_of_omega(omega: np.ndarray, z: np.ndarray, c: np.ndarray, J: np.ndarray) -> np.ndarray:
    """``q = J omega + c z`` (scalars or columns)."""
    return J * omega + c * z


@register_jitable
def omega_of_q(q: np.ndarray, z: np.ndarray, c: np.ndarray, J: np.ndarray) -> np.ndarray:
    """``omega = (q - c z) / J`` (scalars or columns)."""
    return (q - c * z) / J


# inline="always": inlined into the generic stepper's four stages (as a call, the 10 kHz current loop ran about
# 5 % slower than the former staged integrator; benchmarks.elpas_core_speed)
@register_jitable(inline="always")
def rhs_q_row(y: np.ndarray, u: float, rate: float, p: ElpasParams, vehicle: bool, c: float, J: float,
              hyst: bool, k: np.ndarray, pw: np.ndarray) -> None:
    """The right-hand side of one row in the ``(q, z)`` variables, from the point equations on scalars (no
    extensions: the compiled core has none).

    ``y`` and ``k`` ``(n_states,)`` (``y`` in the ``(q, z)`` variables), ``pw`` ``(N_POWER,)``; fills ``k`` and
    every power channel.  ``rate``: dalpha/dt (rig) or dy_r/dt (vehicle); ``(c, J)``: :func:`q_constants`.
    ``hyst``: the row carries the arm hysteresis state (:func:`~vsa_gym.devices.elpas.layout.effect_column`) and
    its ``M_h > 0`` (decided once per step by the caller); otherwise the effect is skipped, ``k`` keeps what the
    caller put in the effect columns (0: the state keeps its value) and the arithmetic is the nominal one.
    """
    dr = p.drive
    gamma, i, z, alpha = y[GAMMA], y[CURRENT], y[BRISTLE], y[ALPHA]
    omega = omega_of_q(y[OMEGA], z, c, J)
    alpha_dot = y[ALPHA_DOT] if vehicle else rate
    stop_M, stop_diss = stop_point(gamma, omega, p.cone.gamma_max, dr.k_stop, dr.d_stop)
    tau_h, p_h = 0.0, 0.0
    if hyst:
        h_col = effect_column(vehicle)
        tau_h, dhz, p_h = arm_hysteresis(p.effects, omega, y[h_col])
        k[h_col] = dhz
    d_omega, d_i, zdot, p_el, p_res, p_fric, p_ext, F_apart = actuator_terms(
        gamma, omega, i, z, alpha, u, alpha_dot, p, 0.0, 0.0, stop_M, tau_h)
    k[GAMMA] = omega
    k[OMEGA] = J * d_omega + c * zdot
    k[CURRENT] = d_i
    k[BRISTLE] = zdot
    pw[P_EL] = p_el
    pw[P_RES] = p_res
    pw[P_FRIC] = p_fric + p_h if hyst else p_fric
    pw[P_EXT] = p_ext
    if vehicle:
        car = p.car
        F_t = tyre_force_point(y[Y_S], alpha, y[Y_R], p)
        bump_M, bump_diss = stop_point(alpha, alpha_dot, p.cone.alpha_max, car.k_bump, car.d_bump)
        d_ad, d_vs, p_damp, p_out = vehicle_terms(alpha, alpha_dot, F_apart, F_t, bump_M, rate, p)
        k[ALPHA] = alpha_dot
        k[ALPHA_DOT] = d_ad
        k[Y_S] = y[V_S]
        k[V_S] = d_vs
        k[Y_R] = rate
        pw[P_STOP] = stop_diss + bump_diss
        pw[P_DAMPER] = p_damp
        pw[P_OUT] = p_out
    else:
        k[ALPHA] = rate
        pw[P_STOP] = stop_diss
        pw[P_DAMPER] = 0.0
        pw[P_OUT] = rig_power_out(F_apart, alpha, rate, p)


# ----------------------------------------------------------------------------- numpy right-hand sides
def extension_ports(p: ElpasParams, x: np.ndarray, alpha_dot: np.ndarray, extensions: Extensions,
                     n_base: int) -> tuple[np.ndarray, np.ndarray]:
    """Sum of the extensions' moments/forces ``(n, N_PORTS)`` and their state derivatives; their states start at
    column ``n_base`` (after the base and the effect states)."""
    n = x.shape[0]
    ports = np.zeros((n, N_PORTS))
    ext_dx = np.zeros((n, x.shape[1] - n_base))
    if not extensions:
        return ports, ext_dx
    gamma, alpha = x[:, GAMMA], x[:, ALPHA]
    sp = spring_unchecked(p.cone, gamma, alpha)
    x_ext_rate = -p.cone.l * np.cos(alpha) * alpha_dot
    ctx = ExtensionContext(p, gamma, x[:, OMEGA], alpha, alpha_dot, x_ext_rate, sp.F_act, sp.T_gamma)
    col = n_base
    for e in extensions:
        k = int(e.n_states)
        out = e.evaluate(ctx, x[:, col:col + k])
        ports[:, 0] += out.torque_gamma
        ports[:, 1] += out.force_act
        ext_dx[:, col - n_base:col - n_base + k] = out.state_derivative
        col += k
    return ports, ext_dx


def rhs_rig(p: ElpasParams, x: np.ndarray, inputs: np.ndarray,
            extensions: Extensions = ()) -> tuple[np.ndarray, np.ndarray]:
    """Right-hand side of the rig (imposed alpha).

    Args:
        p: parameters (floats or ``(n,)`` arrays).
        x: state ``(n, N_RIG + n_eff + n_ext)`` (``n_eff``: :func:`~vsa_gym.devices.elpas.layout.
            effect_state_columns` of ``p``).
        inputs: ``(n, 2)``: voltage (V), ``dalpha/dt`` (rad/s).
        extensions: model extensions (their states follow the base and effect states).

    Returns:
        ``(dxdt, power)`` of shapes ``(n, N_RIG + n_eff + n_ext)`` and ``(n, N_POWER)``.
    """
    n_eff = effect_state_columns(p)
    ports, ext_dx = extension_ports(p, x, inputs[:, IN_ALPHA], extensions, N_RIG + n_eff)
    dx = np.empty_like(x)
    pw = np.empty((x.shape[0], N_POWER))
    _rhs_rig_core(x, inputs, p, ports, dx, pw, N_RIG if n_eff else -1)
    dx[:, N_RIG + n_eff:] = ext_dx
    return dx, pw


def rhs_vehicle(p: ElpasParams, x: np.ndarray, inputs: np.ndarray,
                extensions: Extensions = ()) -> tuple[np.ndarray, np.ndarray]:
    """Right-hand side of the quarter car carried by the eLPAS.

    Args:
        p: parameters (floats or ``(n,)`` arrays).
        x: state ``(n, N_VEHICLE + n_eff + n_ext)`` (as :func:`rhs_rig`).
        inputs: ``(n, 2)``: voltage (V), road rate ``dy_r/dt`` (m/s).
        extensions: model extensions.

    Returns:
        ``(dxdt, power)`` of shapes ``(n, N_VEHICLE + n_eff + n_ext)`` and ``(n, N_POWER)``.
    """
    n_eff = effect_state_columns(p)
    ports, ext_dx = extension_ports(p, x, x[:, ALPHA_DOT], extensions, N_VEHICLE + n_eff)
    dx = np.empty_like(x)
    pw = np.empty((x.shape[0], N_POWER))
    _rhs_vehicle_core(x, inputs, p, ports, dx, pw, N_VEHICLE if n_eff else -1)
    dx[:, N_VEHICLE + n_eff:] = ext_dx
    return dx, pw


def tyre_force_unchecked(p: ElpasParams, x: np.ndarray) -> np.ndarray:
    """Tyre force ``k_t max(y_r - y_u + delta_0, 0)`` (N, >= 0; 0 means lift-off)."""
    return _tyre_force_core(x, p)
