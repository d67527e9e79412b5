"""The generic drive: a motor and a transmission on an inertia (or a motor force on a mass).

One degree of freedom in translation (m, N, kg) or rotation (rad, N m, kg m^2),
selected by ``DriveParams.motion``.  The drive force is the amplifier's::

    F_m = k_u u                     (u: voltage of a current-mode amplifier, or a current, or a force)
    tau_e dF/dt = k_u u - F         (optional first-order amplifier / electrical lag, tau_e > 0)
    tau_e dF/dt = k_u u - b_emf v - F   (voltage drive with inductance: L / R = tau_e, back-EMF in the lag)

``b_emf`` is the part of the viscous ``b`` that is the motor's back-EMF damping
``k_t k_e n^2 / R``: in a voltage drive the back-EMF voltage drives the winding current, so it
acts through the ``L / R`` lag, not instantly (with ``tau_e = 0`` it is simply part of ``b``).

A DC motor in voltage mode with negligible inductance reduces to this form:
:meth:`DriveParams.from_motor` builds ``k_u = k_t n / R`` and the back-EMF damping
``k_t k_e n^2 / R`` (added to ``b``) from :class:`vsa_gym.physics.dc_motor.DCMotorParams`.

Rigid transmission (``k_c = 0`` and ``backlash = 0``): ``m x'' = F_m - F_f(v) - F_0 - h + F_ext`` (efficiency below).
With a compliant transmission or backlash the inertia splits into a motor side
``frac_m m`` and a load side ``(1 - frac_m) m`` joined by the transmission force::

    F_t = k dz(d) + c (v_m - v_l) dz'(d),   d = x_m - x_l,   g = backlash / 2,   e = 0.05 g
    dz(d) = 0                                  |d| <= g - e
          = sign(d) (|d| - g + e)^2 / (4 e)    g - e < |d| < g + e
          = sign(d) (|d| - g)                  |d| >= g + e

``dz`` is a dead zone of total width ``backlash``, exactly free inside (a load floats there, pushed by
nothing) with C1 corners over ``2 e`` (``dz = d`` without backlash).  A contact across the gap is
one-sided: the teeth push, never pull, so where the damping term of a separating contact would
reverse the force, ``F_t = 0``.
With a compliance (``k_c > 0``): ``k = k_c``, ``c = c_c``.
With backlash alone the teeth meet through a stiff, well damped contact that is not a
free parameter, so that backlash adds only the gap: ``k = k_contact`` (default: a
contact mode of :data:`F_CONTACT` = 50 Hz on the reduced mass ``m_r = frac_m (1 - frac_m) m``,
``k = (2 pi 50 Hz)^2 m_r``) and ``c = 2 zeta m_r omega`` with :data:`ZETA_CONTACT` = 0.7.
Load friction (:mod:`vsa_gym.physics.friction` forms)::

    F_f(v) = (F_c + F_s exp(-|v/v_s|^delta_s)) tanh(v / v_eps) + b v

is the steady-state LuGre / Stribeck characteristic (``F_s`` is the static excess
over Coulomb; ``delta_s`` its shape exponent, 2 for LuGre's Gaussian decay, 1 for Tustin's exponential)
with the tanh regularisation of :func:`~vsa_gym.physics.friction.coulomb_viscous_moment`.
With ``sticks = 1`` (a sidecar parameter, or the friction effects' ``sticks`` switch) the friction sticks
instead of creeping, as dry friction does: set-valued at rest, with no regularisation::

    sliding (mode s = +-1):  F_f = s g(v) + b v,   g(v) = F_c + F_s exp(-|v/v_s|^delta_s)
    stuck   (mode s = 0):    v_l = 0 while |F_held| <= F_c + F_s

where ``F_held`` is everything on the load but that friction.  The mode changes are events, located inside the
substep (:func:`_stick_slip_substeps`: a secant on the load speed where it crosses zero, the time at which the
held force reaches the break-away level), so the law is exact between them and sets no substeps.  (An earlier
version approximated sticking by a reset-integrator bristle of a sub-count travel; its give-way took a time of
order ``sqrt(m x_c / F_c)``, and on records of a simulator with exact stiction that lag left errors of several
counts after every reversal, e.g. truth case 37018, which a wider backlash then absorbed.)  With ``sticks = 0``
(the default) the tanh law above
creeps at a speed of order ``v_eps`` under a force below the breakaway level.  ``h`` is a Dahl hysteresis force
(``dh/dt = sigma_h (v - |v| h / F_h)``, presliding travel ``F_h / sigma_h``).  Its decay ``sigma_h |v| / F_h`` is
linear in ``h`` and stiff where the presliding travel is short against the travel of one substep: rows with a
Dahl force are stepped by exponential RK4 (:func:`~vsa_gym.physics.steppers.etd_tuple_stepper`, the decay rate taken
at each substep's start), which integrates that decay exactly, so it does not set the substeps; every other row
is stepped by classical RK4.

Gearbox efficiency acts at the mesh, between the motor-side inertia ``m_m = frac_m m``
(rotor and pinion, reflected) and the load side ``m_l = (1 - frac_m) m``, and depends on the
direction of the mesh power: forward (the motor drives) the load receives ``eta F_mesh``,
back-driven it receives ``F_mesh / eta_b``, where ``F_mesh = F_m - m_m x''`` is the motor force
less the rotor's inertia force.  Rigid::

    forward:     x'' = (eta F_m - L) / (m_l + eta m_m)          L = F_f + F_0 + h - F_ext
    back-driven: x'' = (F_m / eta_b - L) / (m_l + m_m / eta_b)

blended by the sign of ``F_mesh v`` (tanh over ``v_eps``).  With a compliant transmission the
motor side feels the shaft force ``F_t / eta`` (forward) or ``F_t eta_b`` (back-driven).
``eta_b = 0`` means ``eta_b = eta`` (the same efficiency both ways).

Every effect parameter defaults to "absent" (0, or 1 for ``eta``), so the nominal
drive is ``m x'' = k_u u - b v``.  The batched roll-out is compiled by numba: one
row per candidate parameter set, which is what simulation-error least squares needs.
"""

from __future__ import annotations

import dataclasses

import numba
import numpy as np

from vsa_gym.physics.dc_motor import DCMotorParams
from vsa_gym.physics.integrate import etdrk4_weights_scalar
from vsa_gym.physics.parameters import ParameterSet, param
from vsa_gym.physics.steppers import etd_tuple_stepper, rk4_tuple_stepper, tuple_io

PNAMES: tuple[str, ...] = ("m", "b", "k_u", "tau_e", "F_c", "F_s", "v_s", "v_eps", "F_0", "k_c", "c_c", "frac_m",
                           "backlash", "eta", "F_h", "sigma_h", "k_contact", "eta_b",
                           "b_emf", "sticks", "delta_s")
PIDX = {n: i for i, n in enumerate(PNAMES)}
#: observables of the roll-out, in column order
OBS: tuple[str, ...] = ("position", "velocity", "motor_position", "force", "controller_output")
N_STATE = 7  # x_l, v_l, x_m, v_m, F (lagged drive force), h (hysteresis), friction mode (sticks: +-1, 0 stuck)
F_CONTACT = 50.0  # Hz: default backlash contact mode on the reduced mass
ZETA_CONTACT = 0.7  # damping ratio of the backlash contact
E_CORNER = 0.05  # rounding of the dead-zone corners, as a share of the half gap g


@dataclasses.dataclass(frozen=True)
class DriveParams(ParameterSet):
    """Parameters of the generic drive (units for translation; rotation: rad, N m, kg m^2)."""

    m: float = param(1.0, symbol="m", unit="kg", source="record sidecar", tag="proposed", lower=0.0,
                     strict_lower=True, doc="total moving mass / inertia at the load")
    b: float = param(0.0, symbol="b", unit="N s/m", source="record sidecar", tag="proposed", lower=0.0,
                     doc="viscous friction at the load")
    k_u: float = param(1.0, symbol="k_u", unit="N/V", source="record sidecar", tag="proposed",
                       doc="drive gain: force at the load per input unit")
    tau_e: float = param(0.0, symbol="tau_e", unit="s", source="record sidecar", tag="proposed", lower=0.0,
                         doc="amplifier / electrical lag (0: none)")
    F_c: float = param(0.0, symbol="F_c", unit="N", source="effect", tag="proposed", lower=0.0,
                       doc="Coulomb friction level")
    F_s: float = param(0.0, symbol="F_s", unit="N", source="effect", tag="proposed", lower=0.0,
                       doc="static friction excess over Coulomb (Stribeck)")
    v_s: float = param(0.01, symbol="v_s", unit="m/s", source="effect", tag="proposed", lower=0.0,
                       strict_lower=True, doc="Stribeck velocity")
    v_eps: float = param(1e-3, symbol="v_eps", unit="m/s", source="regularisation", tag="numerics", lower=0.0,
                         strict_lower=True, doc="tanh regularisation of sign(v)")
    F_0: float = param(0.0, symbol="F_0", unit="N", source="effect", tag="proposed",
                       doc="constant force offset (opposes +x)")
    k_c: float = param(0.0, symbol="k_c", unit="N/m", source="effect", tag="proposed", lower=0.0,
                       doc="transmission stiffness (0: rigid)")
    c_c: float = param(0.0, symbol="c_c", unit="N s/m", source="effect", tag="proposed", lower=0.0,
                       doc="transmission damping")
    frac_m: float = param(0.5, symbol="m_m/m", unit="-", source="effect", tag="proposed", lower=0.0,
                          strict_lower=True, upper=1.0, doc="motor-side share of the inertia (two-mass case)")
    backlash: float = param(0.0, symbol="2 g", unit="m", source="effect", tag="proposed", lower=0.0,
                            doc="total backlash width")
    eta: float = param(1.0, symbol="eta", unit="-", source="effect", tag="proposed", lower=0.0,
                       strict_lower=True, upper=1.0, doc="transmission efficiency")
    F_h: float = param(0.0, symbol="F_h", unit="N", source="effect", tag="proposed", lower=0.0,
                       doc="Dahl hysteresis loop half-height")
    sigma_h: float = param(1e5, symbol="sigma_h", unit="N/m", source="effect", tag="proposed", lower=0.0,
                           strict_lower=True, doc="Dahl hysteresis initial stiffness")
    k_contact: float = param(0.0, symbol="k_contact", unit="N/m", source="numerics", tag="numerics", lower=0.0,
                             doc="contact stiffness when backlash is present and k_c = 0 (0: a 50 Hz mode on the "
                                 "reduced mass)")
    b_emf: float = param(0.0, symbol="b_emf", unit="N s/m", source="record sidecar", tag="proposed", lower=0.0,
                         doc="the part of b that is a voltage-driven motor's back-EMF (k_t k_e n^2 / R): with a "
                             "lag tau_e = L / R it acts through the winding, tau_e dF/dt = k_u u - b_emf v - F")
    sticks: float = param(0.0, symbol="s", unit="-", source="record sidecar", tag="proposed", lower=0.0, upper=1.0,
                          doc="1: the load friction sticks at rest (set-valued, exact stick-slip events); 0: the tanh "
                              "law over v_eps, which creeps under a force below the break-away level")
    eta_b: float = param(0.0, symbol="eta_b", unit="-", source="effect", tag="proposed", lower=0.0, upper=1.0,
                         doc="back-driven transmission efficiency (load drives the motor); 0: the same as eta")
    delta_s: float = param(2.0, symbol="delta_s", unit="-", source="effect", tag="proposed", lower=0.0,
                           strict_lower=True, doc="Stribeck shape exponent: exp(-|v/v_s|^delta_s) (2: LuGre's "
                                                  "Gaussian, 1: Tustin's exponential; Armstrong-Helouvry 1994)")

    @classmethod
    def from_motor(cls, motor: DCMotorParams, ratio: float, m_load: float, b_load: float = 0.0,
                   **kw: float) -> DriveParams:
        """A voltage-driven DC motor (inductance neglected) through a transmission of ``ratio`` motor rad per
        load unit: ``k_u = k_t ratio / R``, ``b = b_load + (b_m + k_t k_e / R) ratio^2``, ``m = m_load + J ratio^2``."""
        k_u = motor.k_t * ratio / motor.R
        b = b_load + (motor.b + motor.k_t * motor.k_e / motor.R) * ratio**2
        return cls(m=m_load + motor.J * ratio**2, b=b, k_u=k_u, **kw)

    def vector(self, n: int) -> np.ndarray:
        """Flat ``(n, len(PNAMES))`` array for the compiled kernel."""
        out = np.empty((n, len(PNAMES)))
        for i, name in enumerate(PNAMES):
            out[:, i] = np.broadcast_to(np.asarray(getattr(self, name), dtype=np.float64), (n,))
        return out


@numba.njit(cache=True, error_model="numpy", inline="always")
def _contact(P: np.ndarray) -> tuple[float, float]:
    """Stiffness and damping of the transmission: ``(k_c, c_c)`` if compliant, else the backlash contact's."""
    if P[9] > 0.0:
        return P[9], P[10]
    m_r = P[11] * (1.0 - P[11]) * P[0]
    k = P[16] if P[16] > 0.0 else (2.0 * np.pi * F_CONTACT) ** 2 * m_r
    c = P[10] if P[10] > 0.0 else 2.0 * ZETA_CONTACT * np.sqrt(k * m_r)
    return k, c


@numba.njit(cache=True, error_model="numpy", inline="always")
def _tforce(P: np.ndarray, d: float, dv: float) -> float:
    """Transmission force ``k dz(d) + c dv dz'(d)`` (N) at deflection ``d`` and deflection rate ``dv``."""
    k, c = _contact(P)
    g = 0.5 * P[12]
    if g > 0.0:
        # exactly free inside the gap (a load floats there, pushed by nothing), C1 corners of width 2 e
        e = E_CORNER * g
        a = abs(d) - (g - e)
        if a <= 0.0:
            return 0.0
        if a < 2.0 * e:
            dz = a * a / (4.0 * e)
            ddz = a / (2.0 * e)
        else:
            dz = a - e
            ddz = 1.0
        if d < 0.0:
            dz = -dz
        f = k * dz + c * dv * ddz
        # the teeth push, never pull: a separating contact whose damping would pull carries no force
        if f * dz < 0.0:
            return 0.0
        return f
    return k * d + c * dv


@numba.njit(cache=True, error_model="numpy", inline="always")
def _forward(power: float, scale: float) -> float:
    """Share of forward operation (1: the motor drives the load, 0: back-driven) from the mesh power."""
    return 0.5 * (1.0 + np.tanh(power / (scale + 1e-12)))


@numba.njit(cache=True, error_model="numpy", inline="always")
def rhs_point(ctx: tuple[np.ndarray, float, float, bool], y: tuple[float, ...]) -> tuple[float, ...]:
    """The drive's point right-hand side, a pure function in the tuple contract of
    :func:`~vsa_gym.physics.steppers.rk4_tuple_stepper`: ``ctx = (P_row, u, f_ext, two_mass)``, ``y`` the row's
    :data:`N_STATE` states, returns their time derivatives (no power channels)."""
    P, u, fext, two_mass = ctx
    m, b, k_u, tau_e = P[0], P[1], P[2], P[3]
    F_c, F_s, v_s, v_eps, F_0 = P[4], P[5], P[6], P[7], P[8]
    frac, eta, F_h, sig = P[11], P[13], P[14], P[15]
    xl, vl, xm, vm, F, h, mode = y
    b_emf = P[18] if tau_e > 0.0 else 0.0  # back-EMF through the winding's lag (voltage drive)
    if tau_e > 0.0:
        Fm = F
        dF = (k_u * u - b_emf * (vm if two_mass else vl) - F) / tau_e
    else:
        Fm = k_u * u
        dF = 0.0
    b = b - b_emf
    eta_b = P[17] if P[17] > 0.0 else eta
    mm = frac * m
    ml = (1.0 - frac) * m
    d_s = P[20]
    g_v = F_c
    if F_s != 0.0:
        g_v += F_s * (np.exp(-(vl / v_s) ** 2) if d_s == 2.0 else np.exp(-abs(vl / v_s) ** d_s))
    stuck = False
    if P[19] > 0.0 and F_c + F_s > 0.0:
        # friction that sticks (set-valued at rest): the mode is +-1 sliding that way, 0 stuck; it
        # changes only at the events located by _stick_slip_substeps, so the law is exact between them
        Ff = mode * g_v + b * vl
        stuck = mode == 0.0
    else:
        Ff = g_v * np.tanh(vl / v_eps) + b * vl if g_v != 0.0 else b * vl
    dh = sig * (vl - abs(vl) * h / F_h) if F_h > 0.0 else 0.0
    load = Ff + F_0 + h - fext
    if two_mass:
        Ft = _tforce(P, xm - xl, vm - vl)
        if eta < 1.0 or eta_b < 1.0:  # the shaft force seen by the motor side of the mesh
            w = _forward(Ft * vm, abs(Ft) * v_eps)
            Ft = Ft * (w / eta + (1.0 - w) * eta_b)
        return vl, (Ft - load) / ml if ml > 0.0 and not stuck else 0.0, vm, (Fm - Ft) / mm, dF, dh, 0.0
    if eta < 1.0 or eta_b < 1.0:
        # the mesh passes the motor force less the rotor-side inertia force: forward eta (F_m - m_m a),
        # back-driven (F_m - m_m a) / eta_b; the direction is that of the mesh power
        a_f = (eta * Fm - load) / (ml + eta * mm)
        a_b = (Fm / eta_b - load) / (ml + mm / eta_b)
        Fmesh = Fm - mm * a_f
        w = _forward(Fmesh * vl, abs(Fmesh) * v_eps)
        a = w * a_f + (1.0 - w) * a_b
    else:
        a = (Fm - load) / m
    if stuck:
        a = 0.0
    return vl, a, vl, a, dF, dh, 0.0


#: column of the Dahl hysteresis force ``h`` in the state
H_STATE = 5
#: the plain RK4 rows' stepper, inlined into the roll-out; the stick-slip and Dahl paths call steppers compiled once as
#: functions of their own (``*_call``): inlined there too, they made compiling the roll-out slower (measure with
#: ``python -m benchmarks.drive_kernel_speed --compile-only``)
rk4_step = rk4_tuple_stepper(rhs_point, N_STATE)
rk4_call = rk4_tuple_stepper(rhs_point, N_STATE, inline=False)
etd_call = etd_tuple_stepper(rhs_point, N_STATE, H_STATE, inline=False)
load_row, store_row = tuple_io(N_STATE)


@numba.njit(cache=True, error_model="numpy")
def _held_force(P: np.ndarray, s: np.ndarray, u: float, fext: float, two_mass: bool) -> float:
    """The force (N) the friction must take to hold the load at rest in state ``s``: everything on the load but
    the Coulomb and Stribeck friction.  Rigid with a lossy mesh: the motor drives the load (``eta F_m``) where
    that moves it the motor's way, the load back-drives the motor (``F_m / eta_b``) where that moves it against
    the motor, and otherwise the mesh holds (0)."""
    rest = P[8] + s[5] - fext  # F_0 + h - F_ext
    if two_mass:
        return _tforce(P, s[2] - s[0], s[3] - s[1]) - rest - P[1] * s[1]
    Fm = s[4] if P[3] > 0.0 else P[2] * u  # the motor force (as _transmitted gives it; inlined here)
    eta = P[13]
    eta_b = P[17] if P[17] > 0.0 else eta
    if eta >= 1.0 and eta_b >= 1.0:
        return Fm - rest
    fwd = eta * Fm - rest
    if fwd * Fm > 0.0:
        return fwd
    back = Fm / eta_b - rest
    if back * Fm < 0.0:
        return back
    return 0.0


@numba.njit(cache=True, error_model="numpy", inline="always")
def _dahl_step(P: np.ndarray, u: float, fext: float, two_mass: bool, y: tuple[float, ...], h: float
               ) -> tuple[float, ...]:
    """One exponential RK4 substep of ``h`` of a row with a Dahl force, its decay rate ``sigma_h |v_l| / F_h`` (the
    rhs of ``h`` is ``sigma_h v_l - rate h``) taken at the substep's start."""
    lam = P[15] * abs(y[1]) / P[14]
    return etd_call((P, u, fext, two_mass), y, h, lam, etdrk4_weights_scalar(lam, h))


@numba.njit(cache=True, error_model="numpy")
def _one_step(P: np.ndarray, u: float, fext: float, two_mass: bool, dahl: bool, y: tuple[float, ...], h: float
              ) -> tuple[float, ...]:
    """One substep of ``h`` of the row held as the tuple ``y``: exponential RK4 for a row with a Dahl force,
    classical RK4 otherwise."""
    return _dahl_step(P, u, fext, two_mass, y, h) if dahl else rk4_call((P, u, fext, two_mass), y, h, 1)


@numba.njit(cache=True, error_model="numpy")
def _dahl_substeps(P: np.ndarray, u: float, fext: float, two_mass: bool, s: np.ndarray, h: float, n_sub: int) -> None:
    """``n_sub`` exponential RK4 substeps (:func:`_dahl_step`) of a row with a Dahl force, applied to ``s`` in place.
    A call of its own, not inlined, so the row loop of the other rows (classical RK4) compiles as it did before."""
    y = load_row(s)
    for _ in range(n_sub):
        y = _dahl_step(P, u, fext, two_mass, y, h)
    store_row(s, y)


@numba.njit(cache=True, error_model="numpy")
def _stick_slip_substeps(P: np.ndarray, u: float, fext: float, two_mass: bool, dahl: bool, s: np.ndarray, h: float,
                         n_sub: int) -> None:
    """``n_sub`` substeps of a row whose friction sticks, with its mode changes located as events.

    The mode ``s[6]`` is +-1 (sliding that way: friction ``sign * g(v)``) or 0 (stuck: the load at rest).  A
    sliding substep whose load speed crosses zero is cut at the crossing (secant on the speed); there the load
    sticks if the held force (:func:`_held_force`) is within the break-away level ``F_c + F_s``, else it slides
    on the held force's way.  A stuck substep whose held force leaves that level is cut where it does (linear
    in time) and the load breaks away.  Between events the friction law is smooth, so the steps keep their
    order; no regularising speed or bristle spring sets the substeps.  The row is held as a tuple between its
    events (as the plain rows are), which is what keeps this loop near their cost."""
    g0 = P[4] + P[5]
    y = load_row(s)
    for _ in range(n_sub):
        left = h
        events = 0
        while left > 1e-9 * h:
            if y[6] == 0.0 and y[1] != 0.0:
                y = (y[0], y[1], y[2], y[3], y[4], y[5], 1.0 if y[1] > 0.0 else -1.0)  # a start in motion slides
            y0 = y
            y = _one_step(P, u, fext, two_mass, dahl, y0, left)
            if events == 3:
                # a fourth mode change in one substep would be the load chattering: the step stands (the substep
                # is always completed), and a load it leaves moving against its mode is stopped there
                if y[6] != 0.0 and y[6] * y[1] < 0.0:
                    y = (y[0], 0.0, y[2], y[3] if two_mass else 0.0, y[4], y[5], 0.0)
                break
            mode = y[6]
            a1 = 0.0
            if mode != 0.0:  # sliding: did the load speed cross zero?
                v0, v1 = mode * y0[1], mode * y[1]
                if v1 >= 0.0:
                    break
                tau = left * v0 / (v0 - v1) if v0 > 0.0 else 0.0
            else:  # stuck: did the held force leave the break-away level?
                a1 = _held_force(P, y, u, fext, two_mass)
                if abs(a1) <= g0:
                    break
                a0 = _held_force(P, y0, u, fext, two_mass)
                level = g0 if a1 > 0.0 else -g0
                tau = min(max(left * (level - a0) / (a1 - a0), 0.0), left) if a1 != a0 else 0.0
            y = y0  # the substep cut at the event
            if tau > 0.0:
                y = _one_step(P, u, fext, two_mass, dahl, y, tau)
            if mode != 0.0:  # the load stops: it sticks, or slides on the held force's way
                y = (y[0], 0.0, y[2], y[3] if two_mass else 0.0, y[4], y[5], y[6])
                held = _held_force(P, y, u, fext, two_mass)
                y = (y[0], y[1], y[2], y[3], y[4], y[5], 0.0 if abs(held) <= g0 else (1.0 if held > 0.0 else -1.0))
            else:  # it breaks away
                y = (y[0], y[1], y[2], y[3], y[4], y[5], 1.0 if a1 > 0.0 else -1.0)
            events += 1
            left -= tau
    store_row(s, y)


@numba.njit(cache=True, error_model="numpy")
def _transmitted(P: np.ndarray, s: np.ndarray, u: float, two_mass: bool) -> float:
    """Force the drive delivers to the load (N), for the ``force`` observable."""
    if two_mass:
        return _tforce(P, s[2] - s[0], s[3] - s[1])
    return s[4] if P[3] > 0.0 else P[2] * u


@numba.njit(cache=True, error_model="numpy")
def _sensed(xs: np.ndarray, k: int, dt: float, gain: float, offset: float, delay: float, bias: float) -> float:
    """The loop's position sensor at sample ``k``: ``(1 + gain) x(t_k - delay) + offset + bias`` from the
    sampled positions ``xs[:k + 1]`` (linear interpolation, held at the first sample before the start)."""
    if delay <= 0.0:
        x = xs[k]
    else:
        tau = k - delay / dt
        if tau <= 0.0:
            x = xs[0]
        else:
            j = int(np.floor(tau))
            if j >= k:
                x = xs[k]
            else:
                f = tau - j
                x = (1.0 - f) * xs[j] + f * xs[j + 1]
    return (1.0 + gain) * x + offset + bias


@numba.njit(cache=True, error_model="numpy")
def simulate_kernel(P: np.ndarray, x0: np.ndarray, u: np.ndarray, fext: np.ndarray, ref: np.ndarray,
                    ff: np.ndarray, ctrl: np.ndarray, sens: np.ndarray, dt: float, n_sub: int,
                    starts: np.ndarray) -> np.ndarray:
    """Roll out ``n`` drives over ``T`` samples; returns observables ``(T, n, len(OBS))`` at the sample times.

    ``starts`` ``(W + 1,)`` cuts the samples into ``W`` windows ``starts[w] .. starts[w + 1]`` (``starts[0] = 0``,
    ``starts[W] = T``); row ``i`` starts window ``w`` from the state ``x0[w, i]`` (multiple shooting; one window
    ``[0, T]`` is a plain roll-out).
    ``ctrl = [mode, kp, kv, sat, at_motor, bias]``: mode 0 replays ``u`` open loop; mode 1 is the EMPS
    cascade ``u_k = clip(kp kv (ref_k - q_k) - kv (q_k - q_{k-2}) / (2 dt), +-sat) + ff_k`` on the
    loop's sensor ``q_k = (1 + gain) x(t_k - delay) + offset + bias``, where ``x`` is the motor
    position (``at_motor = 1``) or the load's, ``bias`` the sensor's known mean error (a floor
    quantiser's -resolution/2) and ``sens[i] = [gain, offset, delay]`` row ``i``'s sensor terms (one window only:
    the loop's sensor history spans the record).
    """
    n = P.shape[0]
    T = u.shape[0]
    y = np.empty((T, n, 5))
    h = dt / n_sub
    xs = np.empty(T)
    ix = 2 if ctrl[4] == 1.0 else 0
    for i in range(n):
        Pi = P[i]
        two_mass = Pi[9] > 0.0 or Pi[12] > 0.0
        dahl = Pi[14] > 0.0
        sticks = Pi[19] > 0.0 and Pi[4] + Pi[5] > 0.0
        for w in range(starts.shape[0] - 1):
            s = x0[w, i].copy()
            q1 = 0.0
            q2 = 0.0
            for k in range(starts[w], starts[w + 1]):
                if ctrl[0] == 1.0:
                    xs[k] = s[ix]
                    q = _sensed(xs, k, dt, sens[i, 0], sens[i, 1], sens[i, 2], ctrl[5])
                    if k == 0:
                        q1 = q
                        q2 = q
                    dq = (q - q2) / (2.0 * dt)
                    uk = ctrl[1] * ctrl[2] * (ref[k] - q) - ctrl[2] * dq
                    uk = min(max(uk, -ctrl[3]), ctrl[3]) + ff[k]
                    q2 = q1
                    q1 = q
                else:
                    uk = u[k]
                y[k, i, 0] = s[0]
                y[k, i, 1] = s[1]
                y[k, i, 2] = s[2]
                y[k, i, 3] = _transmitted(Pi, s, uk, two_mass)
                y[k, i, 4] = uk
                fk = fext[k]
                if sticks:
                    _stick_slip_substeps(Pi, uk, fk, two_mass, dahl, s, h, n_sub)
                elif dahl:
                    _dahl_substeps(Pi, uk, fk, two_mass, s, h, n_sub)
                else:
                    store_row(s, rk4_step((Pi, uk, fk, two_mass), load_row(s), h, n_sub))
    return y


def contact_stiffness(P: np.ndarray) -> np.ndarray:
    """Stiffness (N/m) of the backlash contact of each row of ``P`` when no compliance ``k_c`` is given:
    ``k_contact``, or by default ``(2 pi F_CONTACT)^2 m_r`` with ``m_r = frac_m (1 - frac_m) m``."""
    P = np.atleast_2d(P)
    m_r = P[:, PIDX["frac_m"]] * (1 - P[:, PIDX["frac_m"]]) * P[:, PIDX["m"]]
    return np.where(P[:, PIDX["k_contact"]] > 0, P[:, PIDX["k_contact"]], (2 * np.pi * F_CONTACT) ** 2 * m_r)


#: most RK4 substeps per sample; a row whose fastest mode needs more may diverge (see :func:`simulate`)
MAX_SUBSTEPS = 400
#: ``h |lambda|`` that classical RK4 is held to for the fastest nonlinear mode (friction, contact, presliding)
RK4_REACH = 1.5
#: ``h / tau_e`` that classical RK4 is held to for the drive lag (see :func:`row_substeps`)
LAG_REACH = 2.5


def lag_rate(P: np.ndarray) -> np.ndarray:
    """Each row's drive-lag rate ``1 / tau_e`` (1/s; 0 without a lag)."""
    tau = P[:, PIDX["tau_e"]]
    return np.where(tau > 0, 1.0 / np.maximum(tau, 1e-12), 0.0)


def fastest_rate(P: np.ndarray, *, lag: bool = True) -> np.ndarray:
    """Each row's fastest mode ``|lambda|`` (1/s) that classical RK4 must resolve: friction regularisation or
    bristles, drive lag (``lag=False``: left out), the Dahl force's presliding spring ``sqrt(2 sigma_h / m_l)``
    (``dh/dt`` is up to ``2 sigma_h v`` on a reversal; its decay ``sigma_h |v| / F_h`` is integrated exactly, see
    :func:`simulate_kernel`), and the transmission's compliance or backlash contact."""
    m = P[:, PIDX["m"]]
    frac = P[:, PIDX["frac_m"]]
    m_load = m * np.where((P[:, PIDX["k_c"]] > 0) | (P[:, PIDX["backlash"]] > 0), 1 - frac + 1e-9, 1.0)
    F_st = P[:, PIDX["F_c"]] + P[:, PIDX["F_s"]]
    sticks = P[:, PIDX["sticks"]] > 0
    rates = [P[:, PIDX["b"]] / m,
             np.where(sticks, 0.0, F_st / (P[:, PIDX["v_eps"]] * m_load)),  # friction that sticks: exact events
             lag_rate(P) if lag else np.zeros_like(m),
             np.sqrt(2.0 * P[:, PIDX["sigma_h"]] / m_load) * (P[:, PIDX["F_h"]] > 0)]
    two = (P[:, PIDX["k_c"]] > 0) | (P[:, PIDX["backlash"]] > 0)
    comp = P[:, PIDX["k_c"]] > 0
    k = np.where(comp, P[:, PIDX["k_c"]], contact_stiffness(P))
    m_r = frac * (1 - frac) * m
    c = np.where(comp | (P[:, PIDX["c_c"]] > 0), P[:, PIDX["c_c"]], 2 * ZETA_CONTACT * np.sqrt(k * m_r))
    mmin = np.minimum(frac, 1 - frac) * m
    rates.append(np.where(two, np.sqrt(k / mmin) + c / mmin, 0.0))
    return np.max(np.stack([np.broadcast_to(r, m.shape) for r in rates]), axis=0)


def row_substeps(P: np.ndarray, dt: float) -> np.ndarray:
    """RK4 substeps each row of ``P`` asks for at the sample time ``dt``: ``h |lambda| <= RK4_REACH`` for its
    fastest mode other than the drive lag, and ``h / tau_e <= LAG_REACH`` for the lag (uncapped).

    The lag ``tau_e dF/dt = k_u u - F`` is linear, and what the motion takes from it is its impulse.  With ``z =
    -h / tau_e``, one RK4 substep multiplies the force's distance from its target by ``R(z) = 1 + z Q(z)`` and
    passes ``h Q(z)`` times that distance to the motion, ``Q(z) = 1 + z/2 + z^2/6 + z^3/24`` (the stage weights).
    Summed over the substeps after a step of the input, the impulse the motion misses is ``h Q / (1 - R) = tau_e``
    times the step, the exact lag's, at any ``z`` where RK4 is stable (``-2.785 < z < 0``): a coarse substep
    changes only how that impulse is spread over the next few substeps, not its size or its first moment (the
    lag's delay).  So the lag is held to the wider reach, with a margin to the stability limit; the nonlinear
    modes (friction, contact), whose error has no such cancellation, to ``RK4_REACH``
    (tests: ``tests/test_integrate.py``)."""
    P = np.atleast_2d(P)
    return np.maximum(np.ceil(fastest_rate(P, lag=False) * dt / RK4_REACH),
                      np.ceil(lag_rate(P) * dt / LAG_REACH)).astype(int)


def substeps(P: np.ndarray, dt: float, base: int = 1) -> int:
    """RK4 substeps per sample for every row of ``P`` (the most any row asks for, :func:`row_substeps`; at least
    ``base``, at most :data:`MAX_SUBSTEPS`)."""
    return int(min(max(base, int(np.max(row_substeps(P, dt)))), MAX_SUBSTEPS))


def simulate(P: np.ndarray, u: np.ndarray, dt: float, *, x0: np.ndarray | None = None,
             fext: np.ndarray | None = None, ref: np.ndarray | None = None, ff: np.ndarray | None = None,
             controller: tuple[float, float, float] | None = None, n_sub: int | None = None,
             sensor_at_motor: bool = True, sensor_bias: float = 0.0, sensor: np.ndarray | None = None,
             diverged: str = "raise", starts: np.ndarray | None = None) -> np.ndarray:
    """Batched roll-out (see :func:`simulate_kernel`); ``P`` is ``(n, len(PNAMES))``, ``u`` is ``(T,)``.

    ``starts`` (multiple shooting, open loop only): the first sample of each window, ascending from 0; ``x0`` is
    then ``(windows, n, N_STATE)``, each window's start states, and each row restarts there (one compiled call
    for all windows, the same arithmetic as one roll-out per window).

    With a ``controller`` ``(kp, kv, saturation)`` the loop reads the position sensor at the motor
    (``sensor_at_motor``) or at the load, with the known ``sensor_bias`` and each row's sensor terms
    ``sensor (n, 3) = [gain, offset, delay]`` (default: none).

    A row whose roll-out is not finite (its fastest mode needs more than :data:`MAX_SUBSTEPS` substeps, or
    its parameters make it unstable) raises a ``FloatingPointError`` naming the rows, the substeps used and
    those the fastest mode asks for (``diverged="raise"``, the default); ``diverged="nan"`` returns such rows
    as they are, for a caller that marks them itself (the identification fit scores a diverged row as
    infinitely bad)."""
    if diverged not in ("raise", "nan"):
        raise ValueError(f"diverged must be 'raise' or 'nan', got {diverged!r}")
    P = np.ascontiguousarray(np.atleast_2d(P), dtype=np.float64)
    u = np.ascontiguousarray(u, dtype=np.float64)
    T, n = u.shape[0], P.shape[0]
    z = np.zeros(T)
    if starts is None:
        cuts = np.array([0, T], dtype=np.int64)
        x0 = np.zeros((n, N_STATE)) if x0 is None else np.broadcast_to(x0, (n, N_STATE))
        x0 = np.ascontiguousarray(x0[None], dtype=np.float64)
    else:
        cuts = np.append(np.asarray(starts, dtype=np.int64), T)
        if controller is not None or cuts[0] != 0 or np.any(np.diff(cuts) <= 0) or x0 is None:
            raise ValueError("starts: open-loop windows from sample 0, ascending and within the samples, with x0 "
                             "(windows, rows, N_STATE) of their start states")
        x0 = np.ascontiguousarray(np.broadcast_to(x0, (len(cuts) - 1, n, N_STATE)), dtype=np.float64)
    ctrl = (np.zeros(6) if controller is None
            else np.array([1.0, *controller, 1.0 if sensor_at_motor else 0.0, float(sensor_bias)]))
    sens = (np.zeros((n, 3)) if sensor is None
            else np.ascontiguousarray(np.broadcast_to(sensor, (n, 3)), dtype=np.float64))
    ns = substeps(P, dt) if n_sub is None else int(n_sub)
    xs = simulate_kernel(P, x0, u, z if fext is None else np.ascontiguousarray(fext, dtype=np.float64),
                         z if ref is None else np.ascontiguousarray(ref, dtype=np.float64),
                         z if ff is None else np.ascontiguousarray(ff, dtype=np.float64), ctrl, sens, float(dt), ns,
                         cuts)
    if diverged == "raise":
        bad = np.flatnonzero(~np.all(np.isfinite(xs), axis=(0, 2)))
        if bad.size:
            need = row_substeps(P[bad[:5]], dt).tolist()
            raise FloatingPointError(
                f"drive roll-out diverged in parameter row(s) {bad[:5].tolist()}{' ...' if bad.size > 5 else ''} "
                f"with {ns} RK4 substeps per sample of {dt:g} s (the fastest mode of those rows asks for {need}, "
                f"capped at {MAX_SUBSTEPS}); check their stiffness, contact, v_eps and tau_e, or pass n_sub")
    return xs
