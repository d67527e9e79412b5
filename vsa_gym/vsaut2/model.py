"""The vsaUT-II lumped-parameter model (paper Sec. III), batched over a leading axis.

Bodies and coordinates
----------------------
* pivot drive: RE-20 motor (current ``i1``, angle ``th1`` relative to the frame,
  speed ``w1``) -> GP26B (n1 = 84) -> sun gear ``theta_s = th1 / n1`` -> pivot
  ``q1 = D_p (1 - cos(gamma theta_s))``;
* frame drive: RE-40 motor (``i2``, ``th2``, ``w2``) -> GP42C (n2 = 156) -> 22-tooth
  pulley -> belt (compliance ``C_belt``) -> 32-tooth pulley on the frame ``q2``;
* output link ``r``, coupled to the frame through the lever springs
  (deflection ``phi = r - q2``).

Equations of motion (``J1 = J_m1 + J_gb1 + I_sun,eq / n1^2``, ``J2 = J_m2 + J_gb2``)::

    L1 di1/dt = u1 - k_e1 w1 - R1 i1
    J1 dw1/dt = k_t1 i1 - b1 w1 - tau_in1(tau_L1, w1) - tau_stop1
    L2 di2/dt = u2 - k_e2 w2 - R2 i2
    J2 dw2/dt = k_t2 i2 - b2 w2 - tau_in2(tau_L2, w2)
    I_ad q2'' = r_op F_b - tau_phi - c_ad q2' - tau_stop2
    I_o  r''  = tau_phi - c_o r' + tau_ext

with ``tau_L1 = -F_q1 dq1/dtheta_s`` (the lever's pivot force seen at the GP26B
output), ``tau_L2 = r_ip F_b`` (belt load on the GP42C output), ``tau_in`` the
gearbox input torque with efficiency losses (:mod:`vsa_gym.physics.gearbox`) and
``tau_phi``, ``F_q1`` the lever forces (:mod:`vsa_gym.physics.lever`).

State layout (``x`` has shape ``(n, 10)``; indices in :data:`STATE`)::

    0 i1 [A]  1 th1 [rad]  2 w1 [rad/s]  3 i2 [A]  4 th2 [rad]  5 w2 [rad/s]
    6 q2 [rad]  7 q2_dot [rad/s]  8 r [rad]  9 r_dot [rad/s]

plus ``sum(ext.n_states)`` trailing columns for extension states.  The belt stretch
is ``r_ip th2 / n2 - r_op q2``.

Inputs: ``u`` of shape ``(n, 2)`` (pivot and frame motor voltages, V) and ``tau_ext``
of shape ``(n,)`` (external torque on the output, N m).

Power channels (:data:`POWER`, shape ``(n, 7)``): electrical power of each motor,
external power on the output, and dissipation in copper, viscous friction,
gearboxes and stops.  Integrated with the state, they satisfy
``E_el1 + E_el2 + W_ext - D = Delta stored_energy`` to integrator accuracy.

Extensions
----------
An :class:`Extension` adds forces at named ports without copying the model:
``"belt_force"`` (N), ``"lever_torque"`` (N m, along phi), ``"pivot_force"`` (N, along q1),
and the joint torques ``"motor1"``, ``"motor2"``, ``"frame"``, ``"output"`` (N m).  It may
carry its own states.  Spring hysteresis (Dahl) fits this shape.

Identified effects that are cheap and stateless -- Coulomb/Stribeck friction at the
output and frame joints, backlash in the belt -- are parameters instead
(``params.effects``, :class:`~vsa_gym.vsaut2.params.VsaUT2Effects`), so they run in the
compiled core and ``gym.make(..., params=...)`` takes them; all zero (the default)
is the nominal model exactly.  Their friction power is in the ``viscous`` channel.
"""

from __future__ import annotations

import dataclasses
import math
import types
from collections.abc import Mapping
from typing import Any, NamedTuple, Protocol

import numba
import numpy as np
from numba.extending import register_jitable

from vsa_gym.physics.belt import belt_force, belt_stiffness_at_frame, input_pulley_radius, series_stiffness
from vsa_gym.physics.contact import two_sided_stop
from vsa_gym.physics.dc_motor import applied_voltage, current_derivative, shaft_torque
from vsa_gym.physics.gearbox import input_torque
from vsa_gym.physics.integrate import etdrk4_weights, exponential_rk4, rk4
from vsa_gym.physics.kernels import flatten_rows, row_reader, scalar_shortcut
from vsa_gym.physics.lever import lever_forces, spring_stiffness
from vsa_gym.physics.parameters import as_batch
from vsa_gym.physics.pivot import pivot_jacobian, pivot_position, sun_inertia
from vsa_gym.vsaut2.params import VsaUT2Params

STATE = {name: i for i, name in enumerate(("i1", "th1", "w1", "i2", "th2", "w2", "q2", "q2_dot", "r", "r_dot"))}
N_STATES = len(STATE)
STATE_UNITS = ("A", "rad", "rad/s", "A", "rad", "rad/s", "rad", "rad/s", "rad", "rad/s")
POWER = {name: i for i, name in enumerate(
    ("el_pivot", "el_frame", "ext", "copper", "viscous", "gearbox", "stops"))}
N_POWER = len(POWER)
PORTS: tuple[str, ...] = ("belt_force", "lever_torque", "pivot_force", "motor1", "motor2", "frame", "output")

#: Smoothing widths of the pivot-stroke stop (rad at the motor) and frame stops (rad) -- numerics.
STOP_EPS_MOTOR = 2e-2
STOP_EPS_FRAME = 2e-3
#: The pivot-stroke stops sit this far (10 smoothing widths) outside [0, th1_max], so a pivot parked at
#: either end of the stroke feels no stop force (< 1e-6 N m).
STOP_MARGIN_MOTOR = 10 * STOP_EPS_MOTOR

#: Default RK4 substeps per 1 ms control step (h = 0.1 ms; see tests/vsaut2/test_integrator.py).
SUBSTEPS_PER_MS = 10
#: Default substeps per 1 ms of the opt-in exponential integrator (``integrator="etd"``, h = 0.143 ms):
#: the fewest that keep all five trajectories of tests/vsaut2/test_integrator.py within 1e-3 of Radau
#: (6 per ms gives 1.1e-3 on the saturating-command run, where the frame sits in its end stop).
ETD_SUBSTEPS_PER_MS = 7
#: The integrators of :meth:`VsaUT2Model.step`: ``"rk4"`` (classical RK4, the default) and ``"etd"``
#: (ETDRK4 with the motor currents' ``-R/L i`` decay integrated exactly, see :class:`VsaUT2Model`).
INTEGRATORS = ("rk4", "etd")
#: State columns whose linear decay the ``"etd"`` integrator treats exactly (the motor currents).
ETD_STIFF = (0, 3)


class _Derived(NamedTuple):
    """Constants derived once per model from the parameters (kept off the hot path)."""

    J1: float | np.ndarray  # pivot drive inertia at the motor (kg m^2)
    J2: float | np.ndarray  # frame drive inertia at the motor (kg m^2)
    r_ip: float | np.ndarray  # input pulley radius (m)
    th1_max: float | np.ndarray  # soft end of the pivot stroke, motor angle (rad)


class Kinematics(NamedTuple):
    """Configuration-level quantities every force element and extension may use (all ``(n,)``)."""

    q1: np.ndarray  # pivot position (m)
    q1_dot: np.ndarray  # pivot speed (m/s)
    phi: np.ndarray  # deflection r - q2 (rad)
    phi_dot: np.ndarray
    delta: np.ndarray  # belt stretch (m)
    delta_dot: np.ndarray
    w1: np.ndarray  # pivot motor speed (rad/s)
    w2: np.ndarray  # frame motor speed (rad/s)
    q2_dot: np.ndarray
    r_dot: np.ndarray


class ExtensionOutput(NamedTuple):
    """What an extension returns: additive forces per port, its state derivative, dissipation."""

    forces: Mapping[str, np.ndarray]
    z_dot: np.ndarray  # (n, n_states)
    p_diss: np.ndarray  # (n,) W, power it dissipates (>= 0 for passive effects)


class Extension(Protocol):
    """A model extension inserted at the ports listed in :data:`PORTS`."""

    name: str
    n_states: int

    def initial_state(self, n: int) -> np.ndarray:
        """Extension states at rest, shape ``(n, n_states)``."""
        ...

    def evaluate(self, params: VsaUT2Params, kin: Kinematics, z: np.ndarray) -> ExtensionOutput:
        """Forces, ``dz/dt`` and dissipated power at configuration ``kin``."""
        ...

    def stored_energy(self, params: VsaUT2Params, kin: Kinematics, z: np.ndarray) -> np.ndarray:
        """Energy the extension stores (J), ``(n,)``; zero for purely dissipative effects."""
        ...


@dataclasses.dataclass(frozen=True)
class VsaUT2Model:
    """The vsaUT-II: parameters plus an optional tuple of extensions.

    ``params`` may be batched (fields of shape ``(n,)``); then ``x`` must have ``n`` rows.

    ``integrator`` (numerics, opt-in): ``"rk4"`` (default) takes ``SUBSTEPS_PER_MS`` classical RK4
    sub-steps per ms: h = 0.1 ms, set by the motor-current poles ``-R/L`` (-9.2e3 and -3.9e3 1/s).
    ``"etd"`` splits each current equation as ``di/dt = -(R/L) i + N(x)`` and integrates the
    linear part exactly (ETDRK4, :func:`vsa_gym.physics.integrate.exponential_rk4`; every other
    state sees classical RK4), so the sub-step is set by the mechanics: ``ETD_SUBSTEPS_PER_MS``
    (h = 0.143 ms), 10/7 fewer right-hand-side evaluations.  The gain stops there because what sets
    the step at 7 per ms is the frame end-stop impact (penalty contact ``K_q2``, ``D_q2``, 2 mrad
    smoothing; a -3.9e3 1/s pole while pressed) on the saturating-command run, not a current pole.
    The linearised poles at rest (``python -m benchmarks.core_modes``) are the pivot-current pole
    (-9.0e3 1/s), the frame-current pole (-3.6e3) and the belt/frame mode (-209 +- 3566j 1/s at
    q1 = 2 mm, 568 Hz, down to -229 +- 862j at 40 mm); with the spring-travel stop engaged the pivot
    gearbox's zero-speed blend adds a real pole of -6.6e4 (q1 = 30 mm) to -5.1e6 1/s (2 mm) that no
    explicit step resolves (a state that command does not set up: measured once by hand).  Plain RK4
    at 7 per ms keeps the states within 3.8e-4 of Radau too, but not the energy channels (1.6e-3 on
    the step run: the copper loss needs the exact current decay).  Both integrators stay within the
    1e-3 Radau bound (tests/vsaut2/test_integrator.py); they differ from each other by up to that
    bound, so ``"rk4"`` stays the default and nothing downstream
    shifts unless asked.
    """

    params: VsaUT2Params = dataclasses.field(default_factory=VsaUT2Params)
    extensions: tuple[Extension, ...] = ()
    compiled: bool = True  # use the numba-compiled RK4 of the same core when there are no extensions
    integrator: str = "rk4"  # "rk4" or "etd" (see the class docstring)

    def __post_init__(self) -> None:
        if self.integrator not in INTEGRATORS:
            raise ValueError(f"integrator must be one of {INTEGRATORS}, got {self.integrator!r}")
        for ext in self.extensions:
            if not isinstance(getattr(ext, "n_states", None), int) or ext.n_states < 0:
                raise ValueError(f"extension {getattr(ext, 'name', ext)!r}: n_states must be an int >= 0")
        p = self.params
        g1 = p.pivot_gearbox
        derived = _Derived(
            J1=p.pivot_motor.J + g1.J_in + sun_inertia(p.pivot) / g1.n**2,
            J2=p.frame_motor.J + p.frame_gearbox.J_in,
            r_ip=input_pulley_radius(p.belt),
            th1_max=p.theta1_max,
        )
        object.__setattr__(self, "_d", derived)
        object.__setattr__(self, "_bs", p.batch_size)  # the property walks every field: once, not per step
        # compiled path: every leaf an (m,) float64 array (m = 1 or n), one numba signature batched or not
        object.__setattr__(self, "p_rows", flatten_rows(p.as_tuple()))
        object.__setattr__(self, "d_rows", flatten_rows(derived))

    @property
    def n_states(self) -> int:
        return N_STATES + sum(e.n_states for e in self.extensions)

    # ------------------------------------------------------------------ states
    def initial_state(
        self, n: int = 1, *, q1: float | np.ndarray | None = None, q2: float | np.ndarray = 0.0,
        r: float | np.ndarray | None = None,
    ) -> np.ndarray:
        """A state at rest, shape ``(n, n_states)``.

        ``q1`` (m) sets the pivot (default: the stiff end, 0); the frame motor angle
        is set so that the belt is unstretched at frame angle ``q2``; ``r`` defaults
        to ``q2`` (undeflected).
        """
        p = self.params
        x = np.zeros((n, self.n_states))
        if q1 is not None:
            from vsa_gym.physics.pivot import sun_angle_for

            x[:, STATE["th1"]] = p.pivot_gearbox.n * sun_angle_for(p.pivot, np.broadcast_to(q1, (n,)))
        x[:, STATE["q2"]] = q2
        x[:, STATE["th2"]] = np.asarray(q2) * p.frame_ratio
        x[:, STATE["r"]] = q2 if r is None else r
        col = N_STATES
        for ext in self.extensions:
            x[:, col:col + ext.n_states] = ext.initial_state(n)
            col += ext.n_states
        return x

    def kinematics(self, x: np.ndarray) -> Kinematics:
        p = self.params
        n1, n2 = p.pivot_gearbox.n, p.frame_gearbox.n
        th_s = x[..., 1] / n1
        jac = pivot_jacobian(p.pivot, th_s)
        r_ip = self._d.r_ip
        return Kinematics(
            q1=pivot_position(p.pivot, th_s),
            q1_dot=jac * x[..., 2] / n1,
            phi=x[..., 8] - x[..., 6],
            phi_dot=x[..., 9] - x[..., 7],
            delta=r_ip * x[..., 4] / n2 - p.belt.r_op * x[..., 6],
            delta_dot=r_ip * x[..., 5] / n2 - p.belt.r_op * x[..., 7],
            w1=x[..., 2],
            w2=x[..., 5],
            q2_dot=x[..., 7],
            r_dot=x[..., 9],
        )

    # ------------------------------------------------------------------ dynamics
    def rhs(self, x: np.ndarray, u: np.ndarray, tau_ext: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Time derivative of ``x`` and the power channels, for held inputs. Shapes as in the module doc."""
        x = np.asarray(x, dtype=np.float64)
        flat = x.ndim == 1
        if flat:
            x, u, tau_ext = x[None, :], np.asarray(u)[None, :], np.atleast_1d(tau_ext)
        if self.compiled and not self.extensions:
            # contiguous float64 inputs keep numba at one compiled signature
            dx, pw = rhs_rows(np.ascontiguousarray(x), np.ascontiguousarray(u, dtype=np.float64),
                                   np.array(np.broadcast_to(tau_ext, x.shape[:1]), dtype=np.float64),
                                   self.p_rows, self.d_rows)
            return (dx[0], pw[0]) if flat else (dx, pw)
        ports = np.zeros((x.shape[0], len(PORTS)))
        p_ext_diss = np.zeros(x.shape[0])
        dz_parts = []
        if self.extensions:
            kin = self.kinematics(x)
            col = N_STATES
            for ext in self.extensions:
                out = ext.evaluate(self.params, kin, x[:, col:col + ext.n_states])
                col += ext.n_states
                for port, f in out.forces.items():
                    if port not in PORTS:
                        raise ValueError(f"extension {ext.name!r} uses unknown port {port!r}; ports: {PORTS}")
                    ports[:, PORTS.index(port)] += f
                dz_parts.append(out.z_dot)
                p_ext_diss += out.p_diss
        dx = np.empty_like(x)
        pw = np.empty((x.shape[0], N_POWER))
        _rhs_core(x, u, tau_ext, self.params, self._d, ports, dx, pw)
        pw[:, 6] += p_ext_diss
        if dz_parts:
            dx[:, N_STATES:] = np.concatenate(dz_parts, axis=-1)
        return (dx[0], pw[0]) if flat else (dx, pw)

    def step(
        self, x: np.ndarray, u: np.ndarray, tau_ext: np.ndarray | float = 0.0, dt: float = 1e-3,
        n_sub: int | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Advance by ``dt`` with inputs held; returns ``(x_new, energy_channels)``.

        Inputs are validated: ``u`` must be finite with shape ``(n, 2)``, ``tau_ext``
        finite with shape ``(n,)`` (or a scalar).  ``ValueError`` names the offender.
        """
        x = np.asarray(x, dtype=np.float64)
        if x.ndim != 2 or x.shape[1] != self.n_states:
            raise ValueError(f"state x: expected shape (n, {self.n_states}), got {x.shape}")
        n = x.shape[0]
        bs = self._bs
        if bs is not None and bs != n:
            raise ValueError(f"state x has {n} rows but the parameter batch has {bs}")
        u = as_batch("u (motor voltages [pivot, frame])", u, n, 2)
        tau = as_batch("tau_ext", tau_ext, n)
        if not np.isfinite(dt) or dt <= 0:
            raise ValueError(f"dt must be a positive finite time step, got {dt}")
        return self._step_valid(x, u, tau, dt, n_sub)

    def _step_valid(
        self, x: np.ndarray, u: np.ndarray, tau: np.ndarray, dt: float, n_sub: int | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`step` for inputs already known valid: float64 ``x`` ``(n, n_states)``, finite ``u`` ``(n, 2)``
        and ``tau`` ``(n,)``, ``dt > 0`` (the environments build them so; their actions are checked on entry).
        Skips the input checks, which cost as much as the compiled integration of one env; the result is
        still checked.
        """
        n = x.shape[0]
        etd = self.integrator == "etd"
        if n_sub is None:  # (math.ceil: the value of np.ceil, a fifth of its call cost)
            n_sub = (max(1, math.ceil(dt / 1e-3 * ETD_SUBSTEPS_PER_MS - 1e-9)) if etd
                     else max(1, math.ceil(dt / 1e-3 * SUBSTEPS_PER_MS)))
        if self.extensions or not self.compiled:
            if etd:
                lam = self.current_decay_rates(n)
                x_new, energy = exponential_rk4(lambda y: self.rhs(y, u, tau), x, dt, n_sub, ETD_STIFF,
                                                lambda y: lam)
            else:
                x_new, energy = rk4(lambda y: self.rhs(y, u, tau), x, dt, n_sub)
        else:
            if etd:
                kernel = etd_rows_parallel if n >= PARALLEL_MIN_ROWS else etd_rows
            else:
                kernel = rk4_rows_parallel if n >= PARALLEL_MIN_ROWS else rk4_rows
            x_new, energy = kernel(np.ascontiguousarray(x), np.ascontiguousarray(u), np.ascontiguousarray(tau),
                                   self.p_rows, self.d_rows, float(dt), int(n_sub))
        if not all_finite(x_new):  # compiled: a third of np.all(np.isfinite(x)) for one env
            raise FloatingPointError("vsaUT-II integration produced a non-finite state; reduce dt")
        return x_new, energy

    def simulate(
        self, x0: np.ndarray, u: np.ndarray, tau_ext: np.ndarray | None = None, dt: float = 1e-3,
        n_sub: int | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Roll out ``T`` steps. ``u``: ``(T, n, 2)``; ``tau_ext``: ``(T, n)``.

        Returns states ``(T + 1, n, n_states)`` and cumulative energy channels ``(T + 1, n, 7)``.
        """
        u = np.asarray(u, dtype=np.float64)
        if u.ndim != 3 or u.shape[2] != 2:
            raise ValueError(f"u: expected shape (T, n, 2), got {u.shape}")
        T = u.shape[0]
        tau = np.zeros(u.shape[:2]) if tau_ext is None else np.asarray(tau_ext, dtype=np.float64)
        if tau.shape != u.shape[:2]:
            raise ValueError(f"tau_ext: expected shape {u.shape[:2]}, got {tau.shape}")
        xs = np.empty((T + 1, *np.shape(x0)))
        es = np.zeros((T + 1, np.shape(x0)[0], N_POWER))
        xs[0] = x0
        x = np.asarray(x0, dtype=np.float64)
        for k in range(T):
            x, e = self.step(x, u[k], tau[k], dt, n_sub)
            xs[k + 1] = x
            es[k + 1] = es[k] + e
        return xs, es

    def current_decay_rates(self, n: int) -> np.ndarray:
        """``R/L`` of the pivot and frame motor circuits (1/s), ``(n, 2)``: the poles ``"etd"`` integrates exactly."""
        m1, m2 = self.params.pivot_motor, self.params.frame_motor
        return np.stack([np.broadcast_to(np.asarray(m.R / m.L, dtype=np.float64), (n,)) for m in (m1, m2)], axis=1)

    # ------------------------------------------------------------------ observables
    def stored_energy(self, x: np.ndarray) -> np.ndarray:
        """Magnetic + kinetic + elastic energy (J), shape ``(n,)``."""
        p = self.params
        m1, m2 = p.pivot_motor, p.frame_motor
        kin = self.kinematics(x)
        d = self._d
        e = 0.5 * (m1.L * x[..., 0] ** 2 + m2.L * x[..., 3] ** 2 + d.J1 * x[..., 2] ** 2 + d.J2 * x[..., 5] ** 2
                   + p.I_ad * x[..., 7] ** 2 + p.I_o * x[..., 9] ** 2)
        e = e + lever_forces(p.lever, kin.q1, kin.phi, kin.q1_dot, kin.phi_dot).energy
        e = e + 0.5 * p.belt.C_belt * kin.delta**2 - 0.5 * p.belt.C_belt * (
            _dead_zone_energy(kin.delta + p.effects.b_belt, p.effects.b_eps)
            - _dead_zone_energy(kin.delta - p.effects.b_belt, p.effects.b_eps))
        zero = 0.0 * x[..., 0]
        e = e + two_sided_stop(x[..., 1], zero, -STOP_MARGIN_MOTOR, d.th1_max + STOP_MARGIN_MOTOR, p.K_s1, p.D_s1,
                               STOP_EPS_MOTOR).energy
        e = e + two_sided_stop(x[..., 6], zero, -p.q2_max, p.q2_max, p.K_q2, p.D_q2, STOP_EPS_FRAME).energy
        col = N_STATES
        for ext in self.extensions:
            e = e + ext.stored_energy(p, kin, x[..., col:col + ext.n_states])
            col += ext.n_states
        return e

    def pivot_position(self, x: np.ndarray) -> np.ndarray:
        """``q1`` (m), shape ``(n,)``."""
        return pivot_position(self.params.pivot, x[..., 1] / self.params.pivot_gearbox.n)

    def stiffness(self, x: np.ndarray, with_belt: bool = True) -> np.ndarray:
        """Output stiffness (N m/rad): eq. (6) at the current deflection, in series with the belt."""
        p = self.params
        K_s = spring_stiffness(p.lever, self.pivot_position(x), x[..., 8] - x[..., 6])
        if not with_belt:
            return K_s
        return series_stiffness(K_s, belt_stiffness_at_frame(p.belt))

    def output_torque(self, x: np.ndarray) -> np.ndarray:
        """Elastic torque the lever applies to the output (N m), ``(n,)``."""
        kin = self.kinematics(x)
        return lever_forces(self.params.lever, kin.q1, kin.phi, kin.q1_dot, kin.phi_dot).tau_phi


def _dead_zone_energy(x: np.ndarray, eps: float | np.ndarray) -> np.ndarray:
    """Antiderivative of ``sqrt(x^2 + eps^2)``: the backlash term of the belt's stored energy."""
    return 0.5 * (x * np.sqrt(x**2 + eps**2) + eps**2 * np.arcsinh(x / eps))


@register_jitable
def _rhs_point(
    p: VsaUT2Params, d: _Derived, i1: Any, th1: Any, w1: Any, i2: Any, th2: Any, w2: Any, q2: Any, q2d: Any,
    r: Any, rd: Any, u_1: Any, u_2: Any, tau_ext: Any, pt0: Any, pt1: Any, pt2: Any, pt3: Any, pt4: Any,
    pt5: Any, pt6: Any,
) -> tuple[tuple[Any, ...], tuple[Any, ...]]:
    """The vsaUT-II equations of motion (module docstring), written once, element-wise.

    Every state, input and port argument is either an ``(n,)`` column (numpy path, ``p`` a
    :class:`VsaUT2Params`) or a float (compiled per-row path, ``p`` one row of the parameter
    tuple, see :func:`vsa_gym.physics.kernels.row_of`).  ``pt0..pt6`` are the additive
    extension forces in :data:`PORTS` order.  Returns the 10 state derivatives and the 7
    power channels.
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
    lev = lever_forces(p.lever, q1, r - q2, q1_dot, rd - q2d)
    F_b = belt_force(p.belt, delta_bl) + pt0
    tau_phi = lev.tau_phi + pt1
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
    )
    pw = (
        u1 * i1,
        u2 * i2,
        tau_ext * rd,
        m1.R * i1**2 + m2.R * i2**2,
        m1.b * w1**2 + m2.b * w2**2 + p.c_ad * q2d**2 + p.c_o * rd**2 + tau_fad * q2d + tau_fo * rd,
        p_gb1 + p_gb2,
        lev.p_diss + stop1.p_diss + stop2.p_diss,
    )
    return dx, pw


def _rhs_core(
    x: np.ndarray, u: np.ndarray, tau_ext: np.ndarray, p: VsaUT2Params, d: _Derived, ports: np.ndarray,
    dx: np.ndarray, pw: np.ndarray,
) -> None:
    """:func:`_rhs_point` on columns (numpy path). ``x``: ``(n, >= 10)``; ``ports``: ``(n, 7)``.

    Fills ``dx`` (first 10 columns) and ``pw`` ``(n, 7)`` in place.
    """
    dxs, pws = _rhs_point(p, d, x[:, 0], x[:, 1], x[:, 2], x[:, 3], x[:, 4], x[:, 5], x[:, 6], x[:, 7], x[:, 8],
                          x[:, 9], u[:, 0], u[:, 1], tau_ext, ports[:, 0], ports[:, 1], ports[:, 2], ports[:, 3],
                          ports[:, 4], ports[:, 5], ports[:, 6])
    for k in range(N_STATES):
        dx[:, k] = dxs[k]
    for k in range(N_POWER):
        pw[:, k] = pws[k]


@register_jitable(inline="always")  # inlined into the RK4/ETD stage loops: ~10 % per RHS, same bits
def _rhs_row(p: Any, d: Any, y: np.ndarray, u_1: float, u_2: float, tau: float, dx: np.ndarray,
             pw: np.ndarray) -> None:
    """:func:`_rhs_point` on one row (floats), no extensions; fills the row vectors ``dx`` and ``pw``."""
    dxs, pws = _rhs_point(p, d, y[0], y[1], y[2], y[3], y[4], y[5], y[6], y[7], y[8], y[9], u_1, u_2, tau,
                          0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    for k in range(N_STATES):
        dx[k] = dxs[k]
    for k in range(N_POWER):
        pw[k] = pws[k]



def _rhs_rows_py(x: np.ndarray, u: np.ndarray, tau: np.ndarray, P: Any, D: Any) -> tuple[np.ndarray, np.ndarray]:
    n = x.shape[0]
    dx = np.empty((n, N_STATES))
    pw = np.empty((n, N_POWER))
    for i in numba.prange(n):
        _rhs_row(P_ROW(P, i), D_ROW(D, i), x[i], u[i, 0], u[i, 1], tau[i], dx[i], pw[i])
    return dx, pw


def _rk4_rows_py(
    x: np.ndarray, u: np.ndarray, tau: np.ndarray, P: Any, D: Any, dt: float, n_sub: int
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`vsa_gym.physics.integrate.rk4` over :func:`_rhs_point`, row by row with floats (no extensions).

    The arithmetic of each element is that of the numpy ``rk4`` (same operations, same order).
    """
    n = x.shape[0]
    h = dt / n_sub
    x_new = np.empty((n, N_STATES))
    energy = np.zeros((n, N_POWER))
    for i in numba.prange(n):
        p = P_ROW(P, i)
        d = D_ROW(D, i)
        u_1, u_2, te = u[i, 0], u[i, 1], tau[i]
        y = x[i].copy()
        yt = np.empty(N_STATES)
        k = np.empty((4, N_STATES))
        q = np.empty((4, N_POWER))
        e = np.zeros(N_POWER)
        for _ in range(n_sub):
            _rhs_row(p, d, y, u_1, u_2, te, k[0], q[0])
            for j in range(N_STATES):
                yt[j] = y[j] + 0.5 * h * k[0, j]
            _rhs_row(p, d, yt, u_1, u_2, te, k[1], q[1])
            for j in range(N_STATES):
                yt[j] = y[j] + 0.5 * h * k[1, j]
            _rhs_row(p, d, yt, u_1, u_2, te, k[2], q[2])
            for j in range(N_STATES):
                yt[j] = y[j] + h * k[2, j]
            _rhs_row(p, d, yt, u_1, u_2, te, k[3], q[3])
            for j in range(N_STATES):
                y[j] = y[j] + (h / 6.0) * (k[0, j] + 2.0 * k[1, j] + 2.0 * k[2, j] + k[3, j])
            for j in range(N_POWER):
                e[j] = e[j] + (h / 6.0) * (q[0, j] + 2.0 * q[1, j] + 2.0 * q[2, j] + q[3, j])
        x_new[i] = y
        energy[i] = e
    return x_new, energy


def _etd_rows_py(
    x: np.ndarray, u: np.ndarray, tau: np.ndarray, P: Any, D: Any, dt: float, n_sub: int
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`vsa_gym.physics.integrate.exponential_rk4` over :func:`_rhs_point`, row by row (no extensions).

    Stiff columns :data:`ETD_STIFF` (the currents) with the constant rates ``R/L`` of the row's
    motors; the weights are those of the numpy step (``etdrk4_weights``), the stages the same
    operations in the same order, so the two paths agree to round-off.
    """
    n = x.shape[0]
    h = dt / n_sub
    x_new = np.empty((n, N_STATES))
    energy = np.zeros((n, N_POWER))
    # rates and weights of row 0; every row's when the parameters are shared (not batched): computed once
    p0 = P_ROW(P, 0)
    lam0 = np.array([p0.pivot_motor.R / p0.pivot_motor.L, p0.frame_motor.R / p0.frame_motor.L])
    w0 = etdrk4_weights(lam0, h)
    shared = P.shape[0] == 1
    for i in numba.prange(n):
        p = P_ROW(P, i)
        d = D_ROW(D, i)
        u_1, u_2, te = u[i, 0], u[i, 1], tau[i]
        if shared:
            lam = lam0
            e_half, w_half, e_full, f_u, f_ab, f_c = w0
        else:
            lam = np.array([p.pivot_motor.R / p.pivot_motor.L, p.frame_motor.R / p.frame_motor.L])
            e_half, w_half, e_full, f_u, f_ab, f_c = etdrk4_weights(lam, h)  # constant over the step
        y = x[i].copy()
        ya = np.empty(N_STATES)
        yb = np.empty(N_STATES)
        yc = np.empty(N_STATES)
        k = np.empty((4, N_STATES))
        q = np.empty((4, N_POWER))
        nl = np.empty((4, 2))
        e = np.zeros(N_POWER)
        for _ in range(n_sub):
            _rhs_row(p, d, y, u_1, u_2, te, k[0], q[0])
            for j in range(N_STATES):
                ya[j] = y[j] + 0.5 * h * k[0, j]
            for s in range(2):
                c = ETD_STIFF[s]
                nl[0, s] = k[0, c] + lam[s] * y[c]
                ya[c] = e_half[s] * y[c] + w_half[s] * nl[0, s]
            _rhs_row(p, d, ya, u_1, u_2, te, k[1], q[1])
            for j in range(N_STATES):
                yb[j] = y[j] + 0.5 * h * k[1, j]
            for s in range(2):
                c = ETD_STIFF[s]
                nl[1, s] = k[1, c] + lam[s] * ya[c]
                yb[c] = e_half[s] * y[c] + w_half[s] * nl[1, s]
            _rhs_row(p, d, yb, u_1, u_2, te, k[2], q[2])
            for j in range(N_STATES):
                yc[j] = y[j] + h * k[2, j]
            for s in range(2):
                c = ETD_STIFF[s]
                nl[2, s] = k[2, c] + lam[s] * yb[c]
                yc[c] = e_half[s] * ya[c] + w_half[s] * (2.0 * nl[2, s] - nl[0, s])
            _rhs_row(p, d, yc, u_1, u_2, te, k[3], q[3])
            for s in range(2):
                c = ETD_STIFF[s]
                nl[3, s] = k[3, c] + lam[s] * yc[c]
            for s in range(2):  # the stiff columns' update uses y at the start of the substep
                c = ETD_STIFF[s]
                ya[c] = e_full[s] * y[c] + h * (f_u[s] * nl[0, s] + f_ab[s] * (nl[1, s] + nl[2, s])
                                                 + f_c[s] * nl[3, s])
            for j in range(N_STATES):
                y[j] = y[j] + (h / 6.0) * (k[0, j] + 2.0 * k[1, j] + 2.0 * k[2, j] + k[3, j])
            for s in range(2):
                y[ETD_STIFF[s]] = ya[ETD_STIFF[s]]
            for j in range(N_POWER):
                e[j] = e[j] + (h / 6.0) * (q[0, j] + 2.0 * q[1, j] + 2.0 * q[2, j] + q[3, j])
        x_new[i] = y
        energy[i] = e
    return x_new, energy


P_ROW = row_reader(VsaUT2Params().as_tuple())
D_ROW = row_reader(_Derived(0.0, 0.0, 0.0, 0.0))

@numba.njit(cache=True)
def all_finite(a: np.ndarray) -> bool:
    """``np.all(np.isfinite(a))`` for a C-contiguous array, without the temporary."""
    for v in a.ravel():  # noqa: SIM110 (a loop numba compiles; no generator)
        if not np.isfinite(v):
            return False
    return True


#: Rows at and above which the compiled step runs its row loop on all cores (numba ``prange``).
PARALLEL_MIN_ROWS = 64


def _parallel_twin(f: Any) -> Any:
    """``f`` under the name ``<name>_parallel``, for its ``parallel=True`` compilation.

    numba names a cache entry after the function's qualified name and first line, and its index key
    (signature, CPU, bytecode) does not include ``parallel``: compiled twice from the same function,
    the serial and the parallel kernels share one cache entry, and whichever was saved first is loaded
    for both -- one env then ran the threaded kernel (tens of us of thread start-up per step), or a
    vector env the serial one.  The twin has its own entry.
    """
    twin = types.FunctionType(f.__code__, f.__globals__, f.__name__ + "_parallel", f.__defaults__, f.__closure__)
    twin.__qualname__ = f.__qualname__ + "_parallel"
    return twin


rhs_rows = numba.njit(cache=True)(_rhs_rows_py)
rk4_rows = numba.njit(cache=True)(_rk4_rows_py)
rk4_rows_parallel = numba.njit(cache=True, parallel=True)(_parallel_twin(_rk4_rows_py))
etd_rows = numba.njit(cache=True)(_etd_rows_py)
etd_rows_parallel = numba.njit(cache=True, parallel=True)(_parallel_twin(_etd_rows_py))
