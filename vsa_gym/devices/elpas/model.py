"""The eLPAS model in two configurations: the hydropulse rig and the quarter car.

Drive (eqs. 1-7): motor current ``i`` through the amplifier limits, reductor
``omega_m = N dgamma/dt``, LuGre friction at the motor shaft, total inertia
``J_r`` about gamma::

    L di/dt        = u_eff - K_E omega_m - R i                       (eq. 1, 2)
    J_r d2gamma/dt2 = N (K_T i - b omega_m - M_fric) + T_gamma + T_stop + T_ext   (eq. 3, 4)
    dz/dt          = omega_m - |omega_m| z / beta(omega_m)           (eq. 6)

``T_gamma`` is the spring moment on the arm (:mod:`vsa_gym.devices.elpas.cone`),
``T_stop`` the gamma end stops (Hunt-Crossley, beyond ``gamma_max``) and
``T_ext`` the sum of the extensions' moments.  The identified effects that the nominal model lacks are
parameters of the compiled core (``params.effects``, :class:`~vsa_gym.devices.elpas.params.ElpasEffects`, all zero
by default): the arm hysteresis (Dahl) adds ``-h`` to the moments on the arm, its state ``h`` an extra column.

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
``Y_R`` constants; the arm hysteresis state ``h_gamma`` follows the base states when some row has
``effects.M_h > 0`` (:data:`EFFECT_STATES`, absent otherwise: the nominal layout), then the extension states.
Power channels (columns of the ``power`` / ``energy`` arrays): ``P_EL`` ... ``P_OUT``, with the
balance ``E_el = dE_stored + E_res + E_fric + E_stop + E_damper + E_ext + E_out``
(:func:`stored_energy`).  ``E_fric`` includes the small elastic bristle energy.

This module is the model's public face: the steps, initial states and observables.  The parts live in
:mod:`~vsa_gym.devices.elpas.layout` (column constants), :mod:`~vsa_gym.devices.elpas.equations` (the equations,
written once as
point functions, and the numpy right-hand sides :func:`rhs_rig` / :func:`rhs_vehicle`),
:mod:`~vsa_gym.devices.elpas.packing` (the parameters for the compiled code) and
:mod:`~vsa_gym.devices.elpas.integrator` (the
integrator, written once as compiled row functions); they are re-exported here.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from vsa_gym.devices.elpas.cone import check_angles, effective_stiffness_unchecked, spring_unchecked
from vsa_gym.devices.elpas.equations import (
    end_stop,
    omega_of_q,
    q_constants,
    q_of_omega,
    rhs_rig,
    rhs_vehicle,
    tyre_force_point,
    tyre_force_unchecked,
)
from vsa_gym.devices.elpas.extensions import check_extensions, total_states
from vsa_gym.devices.elpas.integrator import (
    ETD_STIFF,
    REVERSAL_RATE_H,
    REVERSAL_REFINE,
    advance_row,
    advance_rows,
    reversal_rows,
    substep_count,
)
from vsa_gym.devices.elpas.layout import (
    ALPHA,
    ALPHA_DOT,
    BRISTLE,
    CURRENT,
    EFFECT_STATE_SWITCHES,
    EFFECT_STATES,
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
    effect_column,
    effect_state_columns,
)
from vsa_gym.devices.elpas.packing import N_PARAM_COLS, matrix_row_params, params_matrix, params_tuple, take_rows
from vsa_gym.devices.elpas.params import GRAVITY, ElpasParams
from vsa_gym.physics.dc_motor import applied_voltage
from vsa_gym.physics.friction import bristle_derivative, bristle_rate, lugre_moment
from vsa_gym.physics.integrate import exponential_rk4
from vsa_gym.physics.parameters import as_batch


# ----------------------------------------------------------------------------- stepping
def _check_state(name: str, x: np.ndarray, width: int) -> np.ndarray:
    return as_batch(name, x, width=width)


def _integrate_with_extensions(p: ElpasParams, x: np.ndarray, rin: np.ndarray, extensions: Extensions,
                               vehicle: bool, n_sub: int) -> tuple[np.ndarray, np.ndarray]:
    """The compiled step's scheme on the numpy path, for the extensions (Python objects on columns): the generic
    batched ETDRK4 (:func:`vsa_gym.physics.integrate.exponential_rk4`) over the numpy right-hand side
    (:func:`rhs_rig` / :func:`rhs_vehicle`) in the ``(q, z)`` variables, the bristle rate frozen per substep.

    ``x`` ``(n, n_base + n_ext)``; ``rin`` ``(n, 2)``: voltage, dalpha/dt (rig) or dy_r/dt (vehicle).
    Extension states are integrated by the RK4 part of the scheme (they are not stiff).  The same operations as
    the compiled rows, but numpy's transcendental functions may round differently in the last bit.
    """
    c, J = q_constants(p)
    rhs = rhs_vehicle if vehicle else rhs_rig

    def rhs_q(y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        xs = y.copy()
        xs[:, OMEGA] = omega_of_q(y[:, OMEGA], y[:, BRISTLE], c, J)
        dx, pw = rhs(p, xs, rin, extensions)
        dx[:, OMEGA] = J * dx[:, OMEGA] + c * dx[:, BRISTLE]
        return dx, pw

    def rates(y: np.ndarray) -> np.ndarray:
        return bristle_rate(p.friction, p.drive.N * (y[:, OMEGA] - c * y[:, BRISTLE]) / J)[:, None]

    y = x.copy()
    y[:, OMEGA] = q_of_omega(x[:, OMEGA], x[:, BRISTLE], c, J)
    y, energy = exponential_rk4(rhs_q, y, float(p.numerics.dt), n_sub, ETD_STIFF, rates)
    y[:, OMEGA] = omega_of_q(y[:, OMEGA], y[:, BRISTLE], c, J)
    return y, energy


def _advance(p: ElpasParams, x: np.ndarray, rin: np.ndarray, extensions: Extensions,
             vehicle: bool) -> tuple[np.ndarray, np.ndarray]:
    """One control step of every row: :func:`~vsa_gym.devices.elpas.integrator.advance_rows` (compiled), or with
    extensions :func:`_integrate_with_extensions` and the rows that
    :func:`~vsa_gym.devices.elpas.integrator.needs_refinement` redone with ``REVERSAL_REFINE`` times more substeps."""
    n_sub = substep_count(p)
    dt = float(p.numerics.dt)
    if not extensions:  # the whole step, reversals included, in one compiled call
        return advance_rows(np.ascontiguousarray(x), np.ascontiguousarray(rin), params_matrix(p, x.shape[0]), dt,
                            n_sub, vehicle)
    x = np.ascontiguousarray(x)
    x_new, energy = _integrate_with_extensions(p, x, rin, extensions, vehicle, n_sub)
    rev = reversal_rows(x, x_new, params_matrix(p, x.shape[0]), dt / n_sub)
    if np.any(rev):
        rows = np.flatnonzero(rev)
        p_rows = take_rows(p, rows) if p.batch_size is not None else p
        x_new[rows], energy[rows] = _integrate_with_extensions(p_rows, x[rows], rin[rows], extensions, vehicle,
                                                               n_sub * REVERSAL_REFINE)
    return x_new, energy


def step_rig(p: ElpasParams, x: np.ndarray, inputs: np.ndarray,
             extensions: Extensions = (), compiled: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Advance the rig by one control step ``p.numerics.dt``.

    Args:
        x: state ``(n, N_RIG + n_eff + n_ext)``: ``n_eff = effect_state_columns(p)`` (the arm hysteresis).
        inputs: ``(n, 2)``: voltage (V, held), ``alpha`` at the end of the step
            (rad, within ``+-alpha_max``; alpha moves linearly over the step).
        extensions: model extensions (Python objects: the numpy path of the same scheme).
        compiled: accepted for compatibility and ignored: every step runs the compiled integrator
            (:mod:`vsa_gym.devices.elpas.integrator`).  The first call in a fresh checkout compiles it once
            (30-100 s on a 2-core machine); numba then caches it on disk for every batch size and
            parameter batching.

    Returns:
        ``(x_new, energy)``: new state and the energy of every power channel over
        the step (J), shape ``(n, N_POWER)``.

    Raises:
        ValueError: wrong shapes, non-finite voltage/alpha/state, alpha out of range.
    """
    check_extensions(extensions)
    n_ext = total_states(extensions) if extensions else 0  # (the common case without: no generator)
    x = _check_state("x (rig state)", x, N_RIG + effect_state_columns(p) + n_ext)
    n = x.shape[0]
    inputs = _check_inputs(inputs, n, ("voltage", "alpha"))
    check_angles(p.cone, alpha=inputs[:, IN_ALPHA])
    return _step_rig_valid(p, x, inputs, extensions, compiled)


def _step_rig_valid(p: ElpasParams, x: np.ndarray, inputs: np.ndarray, extensions: Extensions = (),
                    compiled: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """:func:`step_rig` without its input checks, for callers whose inputs are valid by construction
    (float64 ``x`` and finite ``inputs`` ``(n, 2)``, alpha within its range)."""
    del compiled
    dt = float(p.numerics.dt)
    rates_in = inputs.copy()
    rates_in[:, IN_ALPHA] = (inputs[:, IN_ALPHA] - x[:, ALPHA]) / dt
    x_new, energy = _advance(p, x, rates_in, extensions, False)
    x_new[:, ALPHA] = inputs[:, IN_ALPHA]
    return x_new, energy


def step_vehicle(p: ElpasParams, x: np.ndarray, inputs: np.ndarray,
                 extensions: Extensions = (), compiled: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Advance the quarter car by one control step ``p.numerics.dt``.

    Args:
        x: state ``(n, N_VEHICLE + n_eff + n_ext)``.
        inputs: ``(n, 2)``: voltage (V, held), road height at the end of the step
            (m; the road moves linearly over the step).
        extensions, compiled: as :func:`step_rig`.

    Returns:
        ``(x_new, energy)`` as :func:`step_rig`.
    """
    check_extensions(extensions)
    n_ext = total_states(extensions) if extensions else 0  # (the common case without: no generator)
    x = _check_state("x (vehicle state)", x, N_VEHICLE + effect_state_columns(p) + n_ext)
    n = x.shape[0]
    inputs = _check_inputs(inputs, n, ("voltage", "road height"))
    return _step_vehicle_valid(p, x, inputs, extensions, compiled)


def _step_vehicle_valid(p: ElpasParams, x: np.ndarray, inputs: np.ndarray, extensions: Extensions = (),
                        compiled: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """:func:`step_vehicle` without its input checks (as :func:`_step_rig_valid`); the result is still checked."""
    del compiled
    dt = float(p.numerics.dt)
    rates_in = inputs.copy()
    rates_in[:, IN_ROAD] = (inputs[:, IN_ROAD] - x[:, Y_R]) / dt
    x_new, energy = _advance(p, x, rates_in, extensions, True)
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
    """Rig at rest at ``(gamma, alpha)``, zero current, bristle deflection and hysteresis state:
    ``(n, N_RIG + n_eff + n_ext)``."""
    check_angles(p.cone, gamma, alpha)
    x = np.zeros((n, N_RIG + effect_state_columns(p)))
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
    """Quarter car at static equilibrium at ``gamma`` on a road at height 0: ``(n, N_VEHICLE + n_eff + n_ext)``."""
    check_angles(p.cone, gamma=gamma)
    alpha = equilibrium_alpha(p, gamma)
    x = np.zeros((n, N_VEHICLE + effect_state_columns(p)))
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
    """Energy stored in the model (J): inductance, drive kinetic, spring, end stops, the arm hysteresis'
    ``h^2 phi_h / (2 M_h)`` (when ``x`` has its column); for the vehicle also body/wheel/wishbone kinetic, gravity
    and tyre energy.  Shape ``(n,)``."""
    m, dr, c = p.motor, p.drive, p.cone
    e = 0.5 * m.L * x[:, CURRENT] ** 2 + 0.5 * dr.J_r * x[:, OMEGA] ** 2
    e = e + spring_unchecked(c, x[:, GAMMA], x[:, ALPHA]).U
    e = e + end_stop(x[:, GAMMA], x[:, OMEGA], c.gamma_max, dr.k_stop, dr.d_stop)[2]
    h_col = effect_column(vehicle)
    if effect_state_columns(p) and x.shape[1] > h_col:
        M_h, h = p.effects.M_h, x[:, h_col]
        e = e + np.where(M_h > 0.0, 0.5 * h * h * p.effects.phi_h / np.where(M_h > 0.0, M_h, 1.0), 0.0)
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
    "ALPHA", "ALPHA_DOT", "BRISTLE", "CURRENT", "EFFECT_STATES", "EFFECT_STATE_SWITCHES", "GAMMA", "GRAVITY",
    "IN_ALPHA", "IN_ROAD", "IN_VOLTAGE", "N_PARAM_COLS", "N_PORTS", "N_POWER", "N_RIG", "N_VEHICLE", "OMEGA",
    "POWER_NAMES", "P_DAMPER", "P_EL", "P_EXT", "P_FRIC", "P_OUT", "P_RES", "P_STOP", "REVERSAL_RATE_H",
    "REVERSAL_REFINE", "RIG_STATE_NAMES", "VEHICLE_STATE_NAMES", "V_S", "Y_R", "Y_S", "Extensions", "actuator_force_of",
    "advance_row", "disturbance_moment_of", "effect_column", "effect_state_columns", "electrical_power",
    "equilibrium_alpha", "friction_moment", "initial_state_rig", "initial_state_vehicle", "matrix_row_params",
    "motor_speed", "params_matrix", "params_tuple", "rhs_rig", "rhs_vehicle", "step_rig", "step_vehicle",
    "stored_energy", "substep_count", "suspension_travel", "take_rows", "tyre_force", "tyre_force_point",
    "tyre_force_unchecked"
]
