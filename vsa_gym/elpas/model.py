"""The eLPAS model in two configurations: the hydropulse rig and the quarter car.

Drive (eqs. 1-7): motor current ``i`` through the amplifier limits, reductor
``omega_m = N dgamma/dt``, LuGre friction at the motor shaft, total inertia
``J_r`` about gamma::

    L di/dt        = u_eff - K_E omega_m - R i                       (eq. 1, 2)
    J_r d2gamma/dt2 = N (K_T i - b omega_m - M_fric) + T_gamma + T_stop + T_ext   (eq. 3, 4)
    dz/dt          = omega_m - |omega_m| z / beta(omega_m)           (eq. 6)

``T_gamma`` is the spring moment on the arm (:mod:`vsa_gym.elpas.cone`),
``T_stop`` the gamma end stops (Hunt-Crossley, beyond ``gamma_max``) and
``T_ext`` the sum of the extensions' moments.

**Rig** (paper Sec. 5, hydropulse): ``alpha(t)`` is imposed, piecewise linear
between control steps; the state carries ``alpha`` and the rhs input is
``dalpha/dt``.  :func:`step_rig` takes the voltage and ``alpha`` at the *end* of
the step.

**Vehicle** (quarter car / cabin corner): body ``y_s`` (up, from the static
equilibrium), wheel at the wishbone tip ``y_u = y_s + l sin(alpha)``, tyre force
``F_t = k_t max(y_r - y_u + delta_0, 0)`` with ``delta_0 = (m_s + m_u) g / k_t``.
With ``F_apart = F_act + F_ext + c_p l cos(alpha) dalpha/dt`` (pushing body and
wheel apart) and the wishbone inertia ``J_w``, Lagrange's equations in
``(y_s, alpha)`` read::

    (m_s+m_u) y_s'' + m_u l c alpha''               = F_t - (m_s+m_u) g + m_u l s alpha'^2
    m_u l c y_s''   + (m_u l^2 c^2 + J_w) alpha''   = l c (F_t - m_u g - F_apart) + T_bump
                                                      + m_u l^2 c s alpha'^2
    (c = cos alpha, s = sin alpha).

The road height is piecewise linear between control steps: the state carries
``y_r``, the rhs input is ``dy_r/dt``; :func:`step_vehicle` takes the road height
at the end of the step.  The gyroscopic coupling of the drive (mounted on the
wishbone) with ``alpha`` is neglected, as in the paper's force controller.

State layout (columns of ``x``, shape ``(n, n_states)``): see the ``GAMMA`` ...
``Y_R`` constants; extension states follow the base states.  Power channels
(columns of the ``power`` / ``energy`` arrays): ``P_EL`` ... ``P_OUT``, with the
balance ``E_el = dE_stored + E_res + E_fric + E_stop + E_damper + E_ext + E_out``
(:func:`stored_energy`).  ``E_fric`` includes the small elastic bristle energy.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from typing import NamedTuple

import numba
import numpy as np
from numba.extending import register_jitable

from vsa_gym.elpas.cone import check_angles, effective_stiffness_unchecked, spring_unchecked
from vsa_gym.elpas.extensions import (
    Extension,
    ExtensionContext,
    check_extensions,
    total_states,
)
from vsa_gym.elpas.params import GRAVITY, ElpasParams
from vsa_gym.physics.dc_motor import applied_voltage, current_derivative, shaft_torque
from vsa_gym.physics.friction import bristle_derivative, bristle_rate, lugre_moment
from vsa_gym.physics.integrate import etdrk4_weights, exponential_rk4
from vsa_gym.physics.parameters import ParameterSet, as_batch

# ----------------------------------------------------------------------------- state layout
GAMMA = 0  # arm angle gamma (rad)
OMEGA = 1  # dgamma/dt (rad/s); motor speed is N * OMEGA
CURRENT = 2  # motor current i (A)
BRISTLE = 3  # LuGre bristle deflection z at the motor (rad)
ALPHA = 4  # wishbone angle alpha (rad); > 0 compresses the suspension
N_RIG = 5
ALPHA_DOT = 5  # dalpha/dt (rad/s), vehicle only
Y_S = 6  # body (sprung mass) height from static equilibrium (m)
V_S = 7  # body velocity (m/s)
Y_R = 8  # road height under the tyre (m)
N_VEHICLE = 9

RIG_STATE_NAMES = ("gamma", "omega", "current", "bristle", "alpha")
VEHICLE_STATE_NAMES = (*RIG_STATE_NAMES, "alpha_dot", "y_s", "v_s", "y_r")

# ----------------------------------------------------------------------------- inputs
IN_VOLTAGE = 0  # commanded motor voltage u (V)
IN_ALPHA = 1  # rig: step -> alpha at the end of the step (rad); rhs -> dalpha/dt (rad/s)
IN_ROAD = 1  # vehicle: step -> road height at the end of the step (m); rhs -> dy_r/dt (m/s)

# ----------------------------------------------------------------------------- power channels
P_EL = 0  # electrical power from the supply, u_eff i (W)
P_RES = 1  # copper loss R i^2
P_FRIC = 2  # motor + reductor friction (M_fric + b omega_m) omega_m
P_STOP = 3  # dissipation in the gamma end stops (and the wishbone bump stops)
P_DAMPER = 4  # parallel damper c_p (l cos(alpha) dalpha/dt)^2 (vehicle)
P_EXT = 5  # power absorbed by the extensions
P_OUT = 6  # rig: work done on the hydropulse, F_apart dx_ext/dt; vehicle: on the road, -F_t dy_r/dt
N_POWER = 7
POWER_NAMES = ("electrical", "resistive", "friction", "end_stop", "damper", "extensions", "external")

Extensions = tuple[Extension, ...]
N_PORTS = 2  # extension ports: moment on gamma (N m), force added to F_act (N)


# ----------------------------------------------------------------------------- the equations, written once
# The ``*_core`` functions are ``register_jitable``: plain numpy when called with an
# ElpasParams, compiled by numba inside :func:`_step_compiled` with its named tuple.
@register_jitable
def _end_stop(q: np.ndarray, qd: np.ndarray, q_max: np.ndarray | float, k: np.ndarray | float,
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
        moment, dissipated, _ = _end_stop(q, qd, q_max, k, d)
    return moment, dissipated


@register_jitable
def _stop_point(q: float, qd: float, q_max: float, k: float, d: float) -> tuple[float, float]:
    """:func:`_stop_terms` at one point (scalars; the same :func:`_end_stop` in contact, else zero)."""
    if abs(q) > q_max:
        moment, dissipated, _ = _end_stop(q, qd, q_max, k, d)
        return moment, dissipated
    return 0.0, 0.0


# The point equations below take scalars (one row, inside the compiled per-row step) or columns (numpy and
# the columnar wrappers): the physics is written once, and both forms run the same operations in the same order.
@register_jitable
def _actuator_terms(gamma: np.ndarray, omega: np.ndarray, i: np.ndarray, z: np.ndarray, alpha: np.ndarray,
                    u: np.ndarray, alpha_dot: np.ndarray, p: ElpasParams, tau_ext: np.ndarray, f_ext: np.ndarray,
                    stop_M: np.ndarray) -> tuple[np.ndarray, ...]:
    """Drive equations (module docstring) given the end-stop moment ``stop_M``.

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
    d_omega = (dr.N * (shaft_torque(m, i, w_m) - M_fric) + sp.T_gamma + stop_M + tau_ext) / dr.J_r
    d_i = current_derivative(m, u_eff, i, w_m)
    return (d_omega, d_i, zdot, u_eff * i, m.R * i**2, (M_fric + m.b * w_m) * w_m,
            -(tau_ext * omega + f_ext * x_ext_rate), sp.F_act + f_ext)


@register_jitable
def _actuator_core(x: np.ndarray, u: np.ndarray, alpha_dot: np.ndarray, p: ElpasParams, ports: np.ndarray,
                   dx: np.ndarray, pw: np.ndarray) -> np.ndarray:
    """Drive equations on columns: fills ``dx[:, :N_RIG]`` (alpha column excepted) and all
    power channels but ``P_DAMPER``/``P_OUT`` (set to 0); returns ``F_apart = F_act + port force``."""
    dr, c = p.drive, p.cone
    gamma, omega = x[:, GAMMA], x[:, OMEGA]
    stop_M, stop_diss = _stop_terms(gamma, omega, c.gamma_max, dr.k_stop, dr.d_stop)
    d_omega, d_i, zdot, p_el, p_res, p_fric, p_ext, F_apart = _actuator_terms(
        gamma, omega, x[:, CURRENT], x[:, BRISTLE], x[:, ALPHA], u, alpha_dot, p, ports[:, 0], ports[:, 1], stop_M)
    dx[:, GAMMA] = omega
    dx[:, OMEGA] = d_omega
    dx[:, CURRENT] = d_i
    dx[:, BRISTLE] = zdot
    pw[:, P_EL] = p_el
    pw[:, P_RES] = p_res
    pw[:, P_FRIC] = p_fric
    pw[:, P_STOP] = stop_diss
    pw[:, P_DAMPER] = 0.0
    pw[:, P_EXT] = p_ext
    pw[:, P_OUT] = 0.0
    return F_apart


@register_jitable
def _rig_power_out(F_apart: np.ndarray, alpha: np.ndarray, alpha_dot: np.ndarray, p: ElpasParams) -> np.ndarray:
    """Rig: power into the hydropulse, ``F_apart dx_ext/dt``."""
    return F_apart * (-p.cone.l * np.cos(alpha) * alpha_dot)


@register_jitable
def _rhs_rig_core(x: np.ndarray, rin: np.ndarray, p: ElpasParams, ports: np.ndarray, dx: np.ndarray,
                  pw: np.ndarray) -> None:
    """Rig right-hand side into ``dx[:, :N_RIG]`` and ``pw``; ``rin``: voltage, dalpha/dt."""
    alpha_dot = rin[:, IN_ALPHA]
    F_apart = _actuator_core(x, rin[:, IN_VOLTAGE], alpha_dot, p, ports, dx, pw)
    dx[:, ALPHA] = alpha_dot
    pw[:, P_OUT] = _rig_power_out(F_apart, x[:, ALPHA], alpha_dot, p)


@register_jitable
def _tyre_force_point(y_s: np.ndarray, alpha: np.ndarray, y_r: np.ndarray, p: ElpasParams) -> np.ndarray:
    car = p.car
    y_u = y_s + p.cone.l * np.sin(alpha)
    delta0 = (car.m_s + car.m_u) * GRAVITY / car.k_t
    return car.k_t * np.maximum(y_r - y_u + delta0, 0.0)


@register_jitable
def _tyre_force_core(x: np.ndarray, p: ElpasParams) -> np.ndarray:
    return _tyre_force_point(x[:, Y_S], x[:, ALPHA], x[:, Y_R], p)


@register_jitable
def _vehicle_terms(alpha: np.ndarray, alpha_dot: np.ndarray, F_apart: np.ndarray, F_t: np.ndarray,
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
                      pw: np.ndarray) -> None:
    """Quarter-car right-hand side into ``dx[:, :N_VEHICLE]`` and ``pw``; ``rin``: voltage, dy_r/dt."""
    car = p.car
    alpha, alpha_dot = x[:, ALPHA], x[:, ALPHA_DOT]
    F_apart = _actuator_core(x, rin[:, IN_VOLTAGE], alpha_dot, p, ports, dx, pw)
    F_t = _tyre_force_core(x, p)
    bump_M, bump_diss = _stop_terms(alpha, alpha_dot, p.cone.alpha_max, car.k_bump, car.d_bump)
    d_ad, d_vs, p_damp, p_out = _vehicle_terms(alpha, alpha_dot, F_apart, F_t, bump_M, rin[:, IN_ROAD], p)
    dx[:, ALPHA] = alpha_dot
    dx[:, ALPHA_DOT] = d_ad
    dx[:, Y_S] = x[:, V_S]
    dx[:, V_S] = d_vs
    dx[:, Y_R] = rin[:, IN_ROAD]
    pw[:, P_DAMPER] = p_damp
    pw[:, P_STOP] += bump_diss
    pw[:, P_OUT] = p_out


@register_jitable
def _rhs_q_row(y: np.ndarray, u: float, rate: float, p: ElpasParams, vehicle: bool, c: float, J: float,
               k: np.ndarray, pw: np.ndarray) -> None:
    """The right-hand side of one row in the ``(q, z)`` variables of :func:`_integrate` (no extensions),
    from the same point equations on scalars.

    ``y`` and ``k`` ``(n_states,)`` (``y`` in the ``(q, z)`` variables), ``pw`` ``(N_POWER,)``;
    ``rate``: dalpha/dt (rig) or dy_r/dt (vehicle).
    """
    dr = p.drive
    gamma, i, z, alpha = y[GAMMA], y[CURRENT], y[BRISTLE], y[ALPHA]
    omega = (y[OMEGA] - c * z) / J
    alpha_dot = y[ALPHA_DOT] if vehicle else rate
    stop_M, stop_diss = _stop_point(gamma, omega, p.cone.gamma_max, dr.k_stop, dr.d_stop)
    d_omega, d_i, zdot, p_el, p_res, p_fric, p_ext, F_apart = _actuator_terms(
        gamma, omega, i, z, alpha, u, alpha_dot, p, 0.0, 0.0, stop_M)
    k[GAMMA] = omega
    k[OMEGA] = J * d_omega + c * zdot
    k[CURRENT] = d_i
    k[BRISTLE] = zdot
    pw[P_EL] = p_el
    pw[P_RES] = p_res
    pw[P_FRIC] = p_fric
    pw[P_EXT] = p_ext
    if vehicle:
        car = p.car
        F_t = _tyre_force_point(y[Y_S], alpha, y[Y_R], p)
        bump_M, bump_diss = _stop_point(alpha, alpha_dot, p.cone.alpha_max, car.k_bump, car.d_bump)
        d_ad, d_vs, p_damp, p_out = _vehicle_terms(alpha, alpha_dot, F_apart, F_t, bump_M, rate, p)
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
        pw[P_OUT] = _rig_power_out(F_apart, alpha, rate, p)


# ----------------------------------------------------------------------------- numpy entry points
def _extension_ports(p: ElpasParams, x: np.ndarray, alpha_dot: np.ndarray, extensions: Extensions,
                     n_base: int) -> tuple[np.ndarray, np.ndarray]:
    """Sum of the extensions' moments/forces ``(n, N_PORTS)`` and their state derivatives."""
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
        x: state ``(n, N_RIG + n_ext)``.
        inputs: ``(n, 2)``: voltage (V), ``dalpha/dt`` (rad/s).
        extensions: model extensions (their states follow the base states).

    Returns:
        ``(dxdt, power)`` of shapes ``(n, N_RIG + n_ext)`` and ``(n, N_POWER)``.
    """
    ports, ext_dx = _extension_ports(p, x, inputs[:, IN_ALPHA], extensions, N_RIG)
    dx = np.empty_like(x)
    pw = np.empty((x.shape[0], N_POWER))
    _rhs_rig_core(x, inputs, p, ports, dx, pw)
    dx[:, N_RIG:] = ext_dx
    return dx, pw


def rhs_vehicle(p: ElpasParams, x: np.ndarray, inputs: np.ndarray,
                extensions: Extensions = ()) -> tuple[np.ndarray, np.ndarray]:
    """Right-hand side of the quarter car carried by the eLPAS.

    Args:
        p: parameters (floats or ``(n,)`` arrays).
        x: state ``(n, N_VEHICLE + n_ext)``.
        inputs: ``(n, 2)``: voltage (V), road rate ``dy_r/dt`` (m/s).
        extensions: model extensions.

    Returns:
        ``(dxdt, power)`` of shapes ``(n, N_VEHICLE + n_ext)`` and ``(n, N_POWER)``.
    """
    ports, ext_dx = _extension_ports(p, x, x[:, ALPHA_DOT], extensions, N_VEHICLE)
    dx = np.empty_like(x)
    pw = np.empty((x.shape[0], N_POWER))
    _rhs_vehicle_core(x, inputs, p, ports, dx, pw)
    dx[:, N_VEHICLE:] = ext_dx
    return dx, pw


def tyre_force_unchecked(p: ElpasParams, x: np.ndarray) -> np.ndarray:
    """Tyre force ``k_t max(y_r - y_u + delta_0, 0)`` (N, >= 0; 0 means lift-off)."""
    return _tyre_force_core(x, p)


# ----------------------------------------------------------------------------- stepping
def _check_state(name: str, x: np.ndarray, width: int) -> np.ndarray:
    return as_batch(name, x, width=width)


def _n_sub(p: ElpasParams) -> int:
    return int(round(float(p.numerics.n_sub)))


REVERSAL_REFINE = 4
"""Substep refinement for the rows whose motor speed changes sign within a control step."""
REVERSAL_RATE_H = 0.01
"""Refine a reversal only if the bristle rate times the substep exceeds this (slow creep needs no refinement)."""

RhsFn = Callable[[ElpasParams, np.ndarray, np.ndarray, Extensions], tuple[np.ndarray, np.ndarray]]


def take_rows(p: ElpasParams, rows: np.ndarray) -> ElpasParams:
    """The parameter sets of the given batch rows (scalars are shared)."""

    def sub(ps: ParameterSet) -> ParameterSet:
        changes: dict[str, object] = {}
        for f in dataclasses.fields(ps):
            v = getattr(ps, f.name)
            if isinstance(v, ParameterSet):
                changes[f.name] = sub(v)
            elif isinstance(v, np.ndarray):
                changes[f.name] = v[rows]
        return dataclasses.replace(ps, **changes) if changes else ps

    return sub(p)  # type: ignore[return-value]


def _integrate(p: ElpasParams, rhs_fn: RhsFn, x: np.ndarray, rate_inputs: np.ndarray,
               extensions: Extensions, n_sub: int) -> tuple[np.ndarray, np.ndarray]:
    """One control step with the LuGre-aware integrator (numpy; any extensions).

    The bristle damping ``s1 dz/dt`` couples the stiff bristle mode into the
    speed: along that mode ``q = J_r omega + N s1 z`` stays constant.  The step
    therefore integrates ``(q, z)`` instead of ``(omega, z)`` -- ``dq/dt`` contains
    no ``dz/dt`` -- and treats the remaining stiff decay ``-lambda z`` of the
    bristle exactly (:func:`exponential_rk4`, ``lambda = |omega_m| s0 / g``
    frozen per substep).  Stable for any speed; accuracy is checked against Radau.
    """
    c = p.drive.N * p.friction.s1
    J = p.drive.J_r

    def rhs_q(yy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        xx = yy.copy()
        xx[:, OMEGA] = (yy[:, OMEGA] - c * yy[:, BRISTLE]) / J
        dx, power = rhs_fn(p, xx, rate_inputs, extensions)
        dx[:, OMEGA] = J * dx[:, OMEGA] + c * dx[:, BRISTLE]
        return dx, power

    def rates(yy: np.ndarray) -> np.ndarray:
        w = (yy[:, OMEGA] - c * yy[:, BRISTLE]) / J
        return bristle_rate(p.friction, p.drive.N * w)[:, None]

    y = x.copy()
    y[:, OMEGA] = J * x[:, OMEGA] + c * x[:, BRISTLE]
    y_new, energy = exponential_rk4(rhs_q, y, float(p.numerics.dt), n_sub, (BRISTLE,), rates)
    x_new = y_new
    x_new[:, OMEGA] = (y_new[:, OMEGA] - c * y_new[:, BRISTLE]) / J
    return x_new, energy


@register_jitable
def _integrate_row(x: np.ndarray, u: float, rate: float, p: ElpasParams, dt: float, n_sub: int, vehicle: bool,
                   x_out: np.ndarray, e_out: np.ndarray) -> None:
    """:func:`_integrate` for one row (no extensions), compiled: the same ``(q, z)`` ETDRK4, element by element.

    ``x``/``x_out`` ``(n_states,)``, ``e_out`` ``(N_POWER,)`` (overwritten); ``p`` holds this row's
    scalars (:func:`_row_params`); ``u`` the held voltage, ``rate`` dalpha/dt (rig) or dy_r/dt (vehicle).
    """
    nx = x.shape[0]
    c = p.drive.N * p.friction.s1
    J = p.drive.J_r
    h = dt / n_sub
    work = np.empty((8, nx))  # one allocation for the stages (small arrays cost more to allocate than to fill)
    y, k1, k2, k3, k4, ya, yb, yc = work[0], work[1], work[2], work[3], work[4], work[5], work[6], work[7]
    pws = np.empty((4, N_POWER))
    p1, p2, p3, p4 = pws[0], pws[1], pws[2], pws[3]
    for j in range(nx):
        y[j] = x[j]
    y[OMEGA] = J * x[OMEGA] + c * x[BRISTLE]
    for j in range(N_POWER):
        e_out[j] = 0.0
    for _ in range(n_sub):
        lam = bristle_rate(p.friction, p.drive.N * (y[OMEGA] - c * y[BRISTLE]) / J)
        e_half, w_half, e_full, f_u, f_ab, f_c = etdrk4_weights(lam, h)  # the numpy step's weights (integrate.py)
        zs = y[BRISTLE]

        _rhs_q_row(y, u, rate, p, vehicle, c, J, k1, p1)
        n1 = k1[BRISTLE] + lam * zs
        for j in range(nx):
            ya[j] = y[j] + 0.5 * h * k1[j]
        ya[BRISTLE] = e_half * zs + w_half * n1
        _rhs_q_row(ya, u, rate, p, vehicle, c, J, k2, p2)
        n2 = k2[BRISTLE] + lam * ya[BRISTLE]
        for j in range(nx):
            yb[j] = y[j] + 0.5 * h * k2[j]
        yb[BRISTLE] = e_half * zs + w_half * n2
        _rhs_q_row(yb, u, rate, p, vehicle, c, J, k3, p3)
        n3 = k3[BRISTLE] + lam * yb[BRISTLE]
        for j in range(nx):
            yc[j] = y[j] + h * k3[j]
        yc[BRISTLE] = e_half * ya[BRISTLE] + w_half * (2.0 * n3 - n1)
        _rhs_q_row(yc, u, rate, p, vehicle, c, J, k4, p4)
        n4 = k4[BRISTLE] + lam * yc[BRISTLE]
        for j in range(nx):
            y[j] = y[j] + (h / 6.0) * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j])
        y[BRISTLE] = e_full * zs + h * (f_u * n1 + f_ab * (n2 + n3) + f_c * n4)
        for j in range(N_POWER):
            e_out[j] += (h / 6.0) * (p1[j] + 2.0 * p2[j] + 2.0 * p3[j] + p4[j])
    for j in range(nx):
        x_out[j] = y[j]
    x_out[OMEGA] = (y[OMEGA] - c * y[BRISTLE]) / J


@register_jitable
def _advance_row(x: np.ndarray, u: float, rate: float, p: ElpasParams, dt: float, n_sub: int, vehicle: bool,
                 x_out: np.ndarray, e_out: np.ndarray) -> None:
    """:func:`_advance` for one row, compiled: :func:`_integrate_row`, redone with ``REVERSAL_REFINE`` times
    more substeps when the speed reverses through a fast bristle rate (the test of :func:`_reversals_compiled`)."""
    _integrate_row(x, u, rate, p, dt, n_sub, vehicle, x_out, e_out)
    h = dt / n_sub
    w0, w1 = x[OMEGA], x_out[OMEGA]
    fast = max(bristle_rate(p.friction, p.drive.N * w0), bristle_rate(p.friction, p.drive.N * w1)) * h \
        > REVERSAL_RATE_H
    if np.sign(w0) != np.sign(w1) and fast:
        _integrate_row(x, u, rate, p, dt, n_sub * REVERSAL_REFINE, vehicle, x_out, e_out)


@numba.njit(cache=True)
def _step_compiled(x: np.ndarray, rin: np.ndarray, p: ElpasParams, dt: float, n_sub: int,
                   vehicle: bool) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_integrate` compiled (no extensions), row by row (:func:`_integrate_row`); ``p`` the named tuple
    of :func:`_params_tuple`."""
    n = x.shape[0]
    x_new = np.empty_like(x)
    energy = np.empty((n, N_POWER))
    for i in range(n):
        _integrate_row(x[i], rin[i, 0], rin[i, 1], _row_params(p, i), dt, n_sub, vehicle, x_new[i], energy[i])
    return x_new, energy


class _MotorT(NamedTuple):
    L: np.ndarray
    R: np.ndarray
    k_t: np.ndarray
    k_e: np.ndarray
    J: np.ndarray
    b: np.ndarray
    U_max: np.ndarray
    I_max: np.ndarray


class _FrictionT(NamedTuple):
    s0: np.ndarray
    s1: np.ndarray
    s2: np.ndarray
    F_c: np.ndarray
    F_s: np.ndarray
    omega_s: np.ndarray


class _DriveT(NamedTuple):
    N: np.ndarray
    J_r: np.ndarray
    k_stop: np.ndarray
    d_stop: np.ndarray


class _ConeT(NamedTuple):
    a: np.ndarray
    l: np.ndarray
    h: np.ndarray
    r: np.ndarray
    C_a: np.ndarray
    F_s0: np.ndarray
    gamma_max: np.ndarray
    alpha_max: np.ndarray


class _CarT(NamedTuple):
    m_s: np.ndarray
    m_u: np.ndarray
    k_t: np.ndarray
    c_p: np.ndarray
    J_w: np.ndarray
    k_bump: np.ndarray
    d_bump: np.ndarray


class _ElpasT(NamedTuple):
    motor: _MotorT
    friction: _FrictionT
    drive: _DriveT
    cone: _ConeT
    car: _CarT


@register_jitable
def _row_params(p: _ElpasT, i: int) -> _ElpasT:
    """Row ``i`` of the named tuple of :func:`_params_tuple`, as scalars (for the per-row compiled step)."""
    m, fr, dr, c, car = p.motor, p.friction, p.drive, p.cone, p.car
    return _ElpasT(_MotorT(m.L[i], m.R[i], m.k_t[i], m.k_e[i], m.J[i], m.b[i], m.U_max[i], m.I_max[i]),
                   _FrictionT(fr.s0[i], fr.s1[i], fr.s2[i], fr.F_c[i], fr.F_s[i], fr.omega_s[i]),
                   _DriveT(dr.N[i], dr.J_r[i], dr.k_stop[i], dr.d_stop[i]),
                   _ConeT(c.a[i], c.l[i], c.h[i], c.r[i], c.C_a[i], c.F_s0[i], c.gamma_max[i], c.alpha_max[i]),
                   _CarT(car.m_s[i], car.m_u[i], car.k_t[i], car.c_p[i], car.J_w[i], car.k_bump[i], car.d_bump[i]))


_PARAM_GROUPS: tuple[tuple[str, type], ...] = (("motor", _MotorT), ("friction", _FrictionT), ("drive", _DriveT),
                                               ("cone", _ConeT), ("car", _CarT))
N_PARAM_COLS = sum(len(cls._fields) for _, cls in _PARAM_GROUPS)  # 33


@register_jitable
def _matrix_row_params(P: np.ndarray, i: int) -> _ElpasT:
    """Row ``i`` of :func:`_params_matrix` as the scalar named tuple (columns in ``_PARAM_GROUPS`` order)."""
    r = P[i]
    return _ElpasT(_MotorT(r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7]),
                   _FrictionT(r[8], r[9], r[10], r[11], r[12], r[13]),
                   _DriveT(r[14], r[15], r[16], r[17]),
                   _ConeT(r[18], r[19], r[20], r[21], r[22], r[23], r[24], r[25]),
                   _CarT(r[26], r[27], r[28], r[29], r[30], r[31], r[32]))


def _params_matrix(p: ElpasParams, n: int) -> np.ndarray:
    """The parameters as one ``(n, N_PARAM_COLS)`` float64 array, cached on ``p``.

    The compiled per-row steps take this instead of the named tuple of :func:`_params_tuple`: numba
    unboxes one array per call instead of 33 (the tuple alone cost about 20 us per call).
    """
    t = p.__dict__.get("_nb_matrix")
    if t is None or t[0] != n:
        cols = [np.broadcast_to(np.asarray(getattr(getattr(p, g), f), dtype=np.float64), (n,))
                for g, cls in _PARAM_GROUPS for f in cls._fields]
        t = (n, np.ascontiguousarray(np.stack(cols, axis=1)))
        object.__setattr__(p, "_nb_matrix", t)
    return t[1]


def _params_tuple(p: ElpasParams, n: int) -> _ElpasT:
    """The parameters as module-level named tuples of ``(n,)`` float64 arrays.

    One fixed argument type for the compiled step whatever is batched, and
    importable tuple classes, so numba compiles once and caches on disk.
    """
    key = ("_nb_tuple", n)
    t = p.__dict__.get(key[0])
    if t is None or t[0] != n:
        def conv(ps: ParameterSet, cls: type) -> NamedTuple:
            return cls(*(np.array(np.broadcast_to(np.asarray(getattr(ps, f), dtype=np.float64), (n,)))
                         for f in cls._fields))

        t = (n, _ElpasT(conv(p.motor, _MotorT), conv(p.friction, _FrictionT), conv(p.drive, _DriveT),
                        conv(p.cone, _ConeT), conv(p.car, _CarT)))
        object.__setattr__(p, "_nb_tuple", t)
    return t[1]


@numba.njit(cache=True)
def _advance_compiled(x: np.ndarray, rin: np.ndarray, P: np.ndarray, dt: float, n_sub: int,
                      vehicle: bool) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_advance` compiled (no extensions): :func:`_advance_row` for every row, in one call
    (``P``: :func:`_params_matrix`)."""
    n = x.shape[0]
    x_new = np.empty_like(x)
    energy = np.empty((n, N_POWER))
    for i in range(n):
        _advance_row(x[i], rin[i, 0], rin[i, 1], _matrix_row_params(P, i), dt, n_sub, vehicle, x_new[i],
                     energy[i])
    return x_new, energy


def _advance(p: ElpasParams, rhs_fn: RhsFn, x: np.ndarray, rate_inputs: np.ndarray,
             extensions: Extensions, compiled: bool) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_integrate` with ``n_sub`` substeps; rows whose speed reverses are redone finer.

    ``|omega_m|`` in the bristle equation has a kink at zero speed; a substep
    containing the reversal loses two orders of accuracy.  Those rows (sign
    change of ``omega`` over the step, with ``lambda h > REVERSAL_RATE_H`` at
    either end) are recomputed with ``REVERSAL_REFINE`` times more substeps,
    which keeps the Radau error below 1e-3 at little cost.
    """
    n_sub = _n_sub(p)
    if compiled and not extensions:  # the whole step, reversals included, in one compiled call
        return _advance_compiled(np.ascontiguousarray(x), np.ascontiguousarray(rate_inputs),
                                 _params_matrix(p, x.shape[0]), float(p.numerics.dt), n_sub, rhs_fn is rhs_vehicle)
    x_new, energy = _integrate(p, rhs_fn, x, rate_inputs, extensions, n_sub)
    # only reversals through bristle rates that matter within a substep (not presliding creep)
    h = float(p.numerics.dt) / n_sub
    fast = np.maximum(bristle_rate(p.friction, p.drive.N * x[:, OMEGA]),
                      bristle_rate(p.friction, p.drive.N * x_new[:, OMEGA])) * h > REVERSAL_RATE_H
    rev = (np.sign(x[:, OMEGA]) != np.sign(x_new[:, OMEGA])) & fast
    if np.any(rev):
        rows = np.flatnonzero(rev)
        p_rows = take_rows(p, rows) if p.batch_size is not None else p
        x_r, e_r = _integrate(p_rows, rhs_fn, x[rows], rate_inputs[rows], extensions, n_sub * REVERSAL_REFINE)
        x_new[rows] = x_r
        energy[rows] = e_r
    return x_new, energy


def step_rig(p: ElpasParams, x: np.ndarray, inputs: np.ndarray,
             extensions: Extensions = (), compiled: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Advance the rig by one control step ``p.numerics.dt``.

    Args:
        x: state ``(n, N_RIG + n_ext)``.
        inputs: ``(n, 2)``: voltage (V, held), ``alpha`` at the end of the step
            (rad, within ``+-alpha_max``; alpha moves linearly over the step).
        extensions: model extensions (numpy path).
        compiled: use the numba-compiled integrator when there are no extensions
            (same equations and scheme; equal to the numpy path to round-off;
            about 10x faster per step at n = 1).  The first call in a fresh
            checkout compiles it once (30-100 s on this 2-core machine); numba then
            caches it on disk for every batch size and parameter batching.

    Returns:
        ``(x_new, energy)``: new state and the energy of every power channel over
        the step (J), shape ``(n, N_POWER)``.

    Raises:
        ValueError: wrong shapes, non-finite voltage/alpha/state, alpha out of range.
    """
    check_extensions(extensions)
    x = _check_state("x (rig state)", x, N_RIG + total_states(extensions))
    n = x.shape[0]
    inputs = _check_inputs(inputs, n, ("voltage", "alpha"))
    check_angles(p.cone, alpha=inputs[:, IN_ALPHA])
    return _step_rig_valid(p, x, inputs, extensions, compiled)


def _step_rig_valid(p: ElpasParams, x: np.ndarray, inputs: np.ndarray, extensions: Extensions = (),
                    compiled: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """:func:`step_rig` without its input checks, for callers whose inputs are valid by construction
    (the environments: float64 ``x`` and finite ``inputs`` ``(n, 2)``, alpha within its range)."""
    dt = float(p.numerics.dt)
    rates_in = inputs.copy()
    rates_in[:, IN_ALPHA] = (inputs[:, IN_ALPHA] - x[:, ALPHA]) / dt
    x_new, energy = _advance(p, rhs_rig, x, rates_in, extensions, compiled)
    x_new[:, ALPHA] = inputs[:, IN_ALPHA]
    return x_new, energy


def step_vehicle(p: ElpasParams, x: np.ndarray, inputs: np.ndarray,
                 extensions: Extensions = (), compiled: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Advance the quarter car by one control step ``p.numerics.dt``.

    Args:
        x: state ``(n, N_VEHICLE + n_ext)``.
        inputs: ``(n, 2)``: voltage (V, held), road height at the end of the step
            (m; the road moves linearly over the step).
        extensions, compiled: as :func:`step_rig`.

    Returns:
        ``(x_new, energy)`` as :func:`step_rig`.
    """
    check_extensions(extensions)
    x = _check_state("x (vehicle state)", x, N_VEHICLE + total_states(extensions))
    n = x.shape[0]
    inputs = _check_inputs(inputs, n, ("voltage", "road height"))
    return _step_vehicle_valid(p, x, inputs, extensions, compiled)


def _step_vehicle_valid(p: ElpasParams, x: np.ndarray, inputs: np.ndarray, extensions: Extensions = (),
                        compiled: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """:func:`step_vehicle` without its input checks (as :func:`_step_rig_valid`); the result is still checked."""
    dt = float(p.numerics.dt)
    rates_in = inputs.copy()
    rates_in[:, IN_ROAD] = (inputs[:, IN_ROAD] - x[:, Y_R]) / dt
    x_new, energy = _advance(p, rhs_vehicle, x, rates_in, extensions, compiled)
    x_new[:, Y_R] = inputs[:, IN_ROAD]
    if not np.all(np.isfinite(x_new)):
        raise ValueError("step_vehicle: the state became non-finite (check inputs and parameters)")
    return x_new, energy


def _check_inputs(inputs: np.ndarray, n: int, names: Sequence[str]) -> np.ndarray:
    arr = np.asarray(inputs, dtype=np.float64)
    if arr.ndim == 1 and arr.shape[0] == len(names) and n == 1:
        arr = arr[None, :]
    if arr.shape != (n, len(names)):
        raise ValueError(f"inputs: expected shape ({n}, {len(names)}) = ({', '.join(names)}), got {arr.shape}")
    for k, name in enumerate(names):
        bad = ~np.isfinite(arr[:, k])
        if np.any(bad):
            row = int(np.argmax(bad))
            raise ValueError(f"inputs: {name} is not finite ({arr[row, k]!r}) in row {row}")
    return arr


# ----------------------------------------------------------------------------- initial states
def initial_state_rig(p: ElpasParams, n: int, gamma: float | np.ndarray = 0.0, alpha: float | np.ndarray = 0.0,
                      extensions: Extensions = ()) -> np.ndarray:
    """Rig at rest at ``(gamma, alpha)``, zero current and bristle deflection: ``(n, N_RIG + n_ext)``."""
    check_angles(p.cone, gamma, alpha)
    x = np.zeros((n, N_RIG))
    x[:, GAMMA] = gamma
    x[:, ALPHA] = alpha
    ext = [e.initial_state(n) for e in extensions]
    return np.concatenate([x, *ext], axis=1) if ext else x


def equilibrium_alpha(p: ElpasParams, gamma: float | np.ndarray = 0.0) -> np.ndarray:
    """Wishbone angle where ``F_act(gamma, alpha) = m_s g`` (static equilibrium), shape ``(n,)`` or ``()``.

    Newton iteration on the analytic effective stiffness; raises ``ValueError``
    if no solution lies within ``+-alpha_max``.
    """
    c = p.cone
    g = np.asarray(gamma, dtype=np.float64)
    target = p.car.m_s * GRAVITY
    alpha = np.zeros(np.broadcast(g, np.asarray(target), np.asarray(c.l)).shape)
    for _ in range(30):
        f = spring_unchecked(c, g, alpha).F_act - target
        k = effective_stiffness_unchecked(c, g, alpha) * c.l * np.cos(alpha)
        alpha = alpha - f / k
    if not np.all(np.isfinite(alpha)) or np.any(np.abs(alpha) > c.alpha_max):
        raise ValueError(f"equilibrium_alpha: no static equilibrium within alpha_max for gamma={gamma!r}")
    return alpha


def initial_state_vehicle(p: ElpasParams, n: int, gamma: float | np.ndarray = 0.0,
                          extensions: Extensions = ()) -> np.ndarray:
    """Quarter car at static equilibrium at ``gamma`` on a road at height 0: ``(n, N_VEHICLE + n_ext)``."""
    check_angles(p.cone, gamma=gamma)
    alpha = equilibrium_alpha(p, gamma)
    x = np.zeros((n, N_VEHICLE))
    x[:, GAMMA] = gamma
    x[:, ALPHA] = alpha
    x[:, Y_S] = -p.cone.l * np.sin(alpha)
    # static friction moment balances T_gamma(gamma, alpha_eq) (tiny): start with relaxed bristles
    ext = [e.initial_state(n) for e in extensions]
    return np.concatenate([x, *ext], axis=1) if ext else x


# ----------------------------------------------------------------------------- observables
def actuator_force_of(p: ElpasParams, x: np.ndarray) -> np.ndarray:
    """Nominal actuator force ``F_act(gamma, alpha)`` (N), shape ``(n,)`` (no extensions)."""
    return spring_unchecked(p.cone, x[:, GAMMA], x[:, ALPHA]).F_act


def disturbance_moment_of(p: ElpasParams, x: np.ndarray) -> np.ndarray:
    """Spring moment on the arm ``T_gamma`` (N m), shape ``(n,)``."""
    return spring_unchecked(p.cone, x[:, GAMMA], x[:, ALPHA]).T_gamma


def motor_speed(p: ElpasParams, x: np.ndarray) -> np.ndarray:
    """Motor speed ``omega_m = N dgamma/dt`` (rad/s)."""
    return p.drive.N * x[:, OMEGA]


def friction_moment(p: ElpasParams, x: np.ndarray) -> np.ndarray:
    """LuGre friction moment at the motor (N m), eq. 5."""
    w_m = motor_speed(p, x)
    zdot = bristle_derivative(p.friction, w_m, x[:, BRISTLE])
    return lugre_moment(p.friction, w_m, x[:, BRISTLE], zdot)


def electrical_power(p: ElpasParams, x: np.ndarray, voltage: np.ndarray) -> np.ndarray:
    """Power drawn from the supply ``u_eff i`` (W) for the commanded voltage."""
    u_eff = applied_voltage(p.motor, np.asarray(voltage, dtype=np.float64), x[:, CURRENT], motor_speed(p, x))
    return u_eff * x[:, CURRENT]


def tyre_force(p: ElpasParams, x: np.ndarray) -> np.ndarray:
    """Tyre force (N), shape ``(n,)``; 0 when the wheel has lifted off (vehicle state)."""
    return tyre_force_unchecked(p, x)


def suspension_travel(p: ElpasParams, x: np.ndarray) -> np.ndarray:
    """Compression ``l sin(alpha)`` (m)."""
    return p.cone.l * np.sin(x[:, ALPHA])


def stored_energy(p: ElpasParams, x: np.ndarray, vehicle: bool) -> np.ndarray:
    """Energy stored in the model (J): inductance, drive kinetic, spring, end stops; for the
    vehicle also body/wheel/wishbone kinetic, gravity and tyre energy.  Shape ``(n,)``."""
    m, dr, c = p.motor, p.drive, p.cone
    e = 0.5 * m.L * x[:, CURRENT] ** 2 + 0.5 * dr.J_r * x[:, OMEGA] ** 2
    e = e + spring_unchecked(c, x[:, GAMMA], x[:, ALPHA]).U
    e = e + _end_stop(x[:, GAMMA], x[:, OMEGA], c.gamma_max, dr.k_stop, dr.d_stop)[2]
    if vehicle:
        car = p.car
        alpha, ad, vs = x[:, ALPHA], x[:, ALPHA_DOT], x[:, V_S]
        ca = np.cos(alpha)
        e = e + 0.5 * (car.m_s + car.m_u) * vs**2 + car.m_u * c.l * ca * vs * ad
        e = e + 0.5 * (car.m_u * (c.l * ca) ** 2 + car.J_w) * ad**2
        y_u = x[:, Y_S] + c.l * np.sin(alpha)
        e = e + GRAVITY * (car.m_s * x[:, Y_S] + car.m_u * y_u)
        e = e + 0.5 * tyre_force_unchecked(p, x) ** 2 / car.k_t
        e = e + _end_stop(alpha, ad, c.alpha_max, car.k_bump, car.d_bump)[2]
    return e
