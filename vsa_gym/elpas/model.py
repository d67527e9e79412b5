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

The column constants live in :mod:`~vsa_gym.elpas.layout`, the equations (written once as point functions, and
the numpy right-hand sides :func:`rhs_rig` / :func:`rhs_vehicle`) in :mod:`~vsa_gym.elpas.equations`, the
parameters packed for the compiled code in :mod:`~vsa_gym.elpas.packing`; they are re-exported here.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numba
import numpy as np
from numba.extending import register_jitable

from vsa_gym.elpas.cone import check_angles, effective_stiffness_unchecked, spring_unchecked
from vsa_gym.elpas.equations import (
    end_stop,
    rhs_q_row,
    rhs_rig,
    rhs_vehicle,
    tyre_force_point,
    tyre_force_unchecked,
)
from vsa_gym.elpas.extensions import check_extensions, total_states
from vsa_gym.elpas.layout import (
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
    POWER_NAMES,
    RIG_STATE_NAMES,
    V_S,
    VEHICLE_STATE_NAMES,
    Y_R,
    Y_S,
    Extensions,
)
from vsa_gym.elpas.packing import (
    N_PARAM_COLS,
    matrix_row_params,
    params_matrix,
    params_tuple,
    row_params,
    take_rows,
)
from vsa_gym.elpas.params import GRAVITY, ElpasParams
from vsa_gym.physics.dc_motor import applied_voltage
from vsa_gym.physics.friction import bristle_derivative, bristle_rate, lugre_moment
from vsa_gym.physics.integrate import etdrk4_weights, exponential_rk4
from vsa_gym.physics.parameters import as_batch

# the names other modules import from here, until they import the public ones
_matrix_row_params = matrix_row_params
_params_matrix = params_matrix
_params_tuple = params_tuple
_tyre_force_point = tyre_force_point


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
    scalars (:func:`~vsa_gym.elpas.packing.row_params`); ``u`` the held voltage, ``rate`` dalpha/dt (rig) or
    dy_r/dt (vehicle).
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

        rhs_q_row(y, u, rate, p, vehicle, c, J, 0.0, 0.0, k1, p1)
        n1 = k1[BRISTLE] + lam * zs
        for j in range(nx):
            ya[j] = y[j] + 0.5 * h * k1[j]
        ya[BRISTLE] = e_half * zs + w_half * n1
        rhs_q_row(ya, u, rate, p, vehicle, c, J, 0.0, 0.0, k2, p2)
        n2 = k2[BRISTLE] + lam * ya[BRISTLE]
        for j in range(nx):
            yb[j] = y[j] + 0.5 * h * k2[j]
        yb[BRISTLE] = e_half * zs + w_half * n2
        rhs_q_row(yb, u, rate, p, vehicle, c, J, 0.0, 0.0, k3, p3)
        n3 = k3[BRISTLE] + lam * yb[BRISTLE]
        for j in range(nx):
            yc[j] = y[j] + h * k3[j]
        yc[BRISTLE] = e_half * ya[BRISTLE] + w_half * (2.0 * n3 - n1)
        rhs_q_row(yc, u, rate, p, vehicle, c, J, 0.0, 0.0, k4, p4)
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
    of :func:`params_tuple`."""
    n = x.shape[0]
    x_new = np.empty_like(x)
    energy = np.empty((n, N_POWER))
    for i in range(n):
        _integrate_row(x[i], rin[i, 0], rin[i, 1], row_params(p, i), dt, n_sub, vehicle, x_new[i], energy[i])
    return x_new, energy

@numba.njit(cache=True)
def _advance_compiled(x: np.ndarray, rin: np.ndarray, P: np.ndarray, dt: float, n_sub: int,
                      vehicle: bool) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_advance` compiled (no extensions): :func:`_advance_row` for every row, in one call
    (``P``: :func:`~vsa_gym.elpas.packing.params_matrix`)."""
    n = x.shape[0]
    x_new = np.empty_like(x)
    energy = np.empty((n, N_POWER))
    for i in range(n):
        _advance_row(x[i], rin[i, 0], rin[i, 1], matrix_row_params(P, i), dt, n_sub, vehicle, x_new[i],
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
                                 params_matrix(p, x.shape[0]), float(p.numerics.dt), n_sub, rhs_fn is rhs_vehicle)
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
    e = e + end_stop(x[:, GAMMA], x[:, OMEGA], c.gamma_max, dr.k_stop, dr.d_stop)[2]
    if vehicle:
        car = p.car
        alpha, ad, vs = x[:, ALPHA], x[:, ALPHA_DOT], x[:, V_S]
        ca = np.cos(alpha)
        e = e + 0.5 * (car.m_s + car.m_u) * vs**2 + car.m_u * c.l * ca * vs * ad
        e = e + 0.5 * (car.m_u * (c.l * ca) ** 2 + car.J_w) * ad**2
        y_u = x[:, Y_S] + c.l * np.sin(alpha)
        e = e + GRAVITY * (car.m_s * x[:, Y_S] + car.m_u * y_u)
        e = e + 0.5 * tyre_force_unchecked(p, x) ** 2 / car.k_t
        e = e + end_stop(alpha, ad, c.alpha_max, car.k_bump, car.d_bump)[2]
    return e


__all__ = [
    "ALPHA", "ALPHA_DOT", "BRISTLE", "CURRENT", "GAMMA", "GRAVITY", "IN_ALPHA", "IN_ROAD", "IN_VOLTAGE", "N_PARAM_COLS",
    "N_PORTS", "N_POWER", "N_RIG", "N_VEHICLE", "OMEGA", "POWER_NAMES", "P_DAMPER", "P_EL", "P_EXT", "P_FRIC", "P_OUT",
    "P_RES", "P_STOP", "REVERSAL_RATE_H", "REVERSAL_REFINE", "RIG_STATE_NAMES", "VEHICLE_STATE_NAMES", "V_S", "Y_R",
    "Y_S", "Extensions", "actuator_force_of", "disturbance_moment_of", "electrical_power", "equilibrium_alpha",
    "friction_moment", "initial_state_rig", "initial_state_vehicle", "matrix_row_params", "motor_speed",
    "params_matrix", "params_tuple", "rhs_rig", "rhs_vehicle", "step_rig", "step_vehicle", "stored_energy",
    "suspension_travel", "take_rows", "tyre_force", "tyre_force_point", "tyre_force_unchecked",
]
