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
``tau_phi``, ``F_q1`` the lever forces (:mod:`vsa_gym.devices.vsaut2.lever`).

State layout (``x`` has shape ``(n, 10)``; indices in :data:`STATE`)::

    0 i1 [A]  1 th1 [rad]  2 w1 [rad/s]  3 i2 [A]  4 th2 [rad]  5 w2 [rad/s]
    6 q2 [rad]  7 q2_dot [rad/s]  8 r [rad]  9 r_dot [rad/s]

then the effect states of ``params.effects`` that are switched on (:data:`EFFECT_STATE`: column 10 is the
spring hysteresis torque ``h_phi`` [N m] when some row has ``effects.M_h > 0``; absent otherwise, the nominal
10-column layout), then ``sum(ext.n_states)`` trailing columns for extension states.  The belt stretch
is ``r_ip th2 / n2 - r_op q2``.

Inputs: ``u`` of shape ``(n, 2)`` (pivot and frame motor voltages, V) and ``tau_ext``
of shape ``(n,)`` (external torque on the output, N m).

Power channels (:data:`POWER`, shape ``(n, 7)``): electrical power of each motor,
external power on the output, and dissipation in copper, viscous friction (with the identified friction
effects and the spring hysteresis), gearboxes and stops (with the extensions' dissipation).  Integrated with
the state, they satisfy ``E_el1 + E_el2 + W_ext - D = Delta stored_energy`` to integrator accuracy.

Extensions
----------
An :class:`Extension` adds forces at named ports without copying the model:
``"belt_force"`` (N), ``"lever_torque"`` (N m, along phi), ``"pivot_force"`` (N, along q1),
and the joint torques ``"motor1"``, ``"motor2"``, ``"frame"``, ``"output"`` (N m).  It may
carry its own states.  Extensions run on the numpy path only: one 1 ms step of 8 rows took 9.6 ms of CPU with a
Dahl extension against 74 us for the compiled core with the same law as a state column
(``python -m benchmarks.vsaut2_hysteresis_speed``).

Identified effects -- Coulomb/Stribeck friction at the output and frame joints, backlash in the belt, and the
stateful spring hysteresis (Dahl, one state column) -- are parameters instead (``params.effects``,
:class:`~vsa_gym.devices.vsaut2.params.VsaUT2Effects`), so they run in the compiled core and
``gym.make(..., params=...)`` takes them; all zero (the default) is the nominal model exactly.  Their friction
power is in the ``viscous`` channel; the hysteresis' stored part is in :meth:`VsaUT2Model.stored_energy`.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from vsa_gym.devices.vsaut2.belt import belt_stiffness_at_frame, input_pulley_radius, series_stiffness
from vsa_gym.devices.vsaut2.equations import dead_zone_energy, rhs_core, rhs_point, rhs_row  # noqa: F401
from vsa_gym.devices.vsaut2.kernels import (  # noqa: F401  (re-exported: the environments and identification call them)
    D_ROW,
    P_ROW,
    PARALLEL_MIN_ROWS,
    all_finite,
    etd_rows,
    etd_rows_parallel,
    rhs_rows,
    rk4_rows,
    rk4_rows_parallel,
)
from vsa_gym.devices.vsaut2.layout import (  # noqa: F401  (re-exported: part of this module's public names)
    EFFECT_STATE,
    EFFECT_STATE_SWITCHES,
    EFFECT_STATE_UNITS,
    ETD_STIFF,
    ETD_SUBSTEPS_PER_MS,
    INTEGRATORS,
    N_POWER,
    N_STATES,
    PORTS,
    POWER,
    STATE,
    STATE_UNITS,
    STOP_EPS_FRAME,
    STOP_EPS_MOTOR,
    STOP_MARGIN_MOTOR,
    SUBSTEPS_PER_MS,
    Extension,
    ExtensionOutput,
    Kinematics,
    effect_state_columns,
)
from vsa_gym.devices.vsaut2.layout import Derived as _Derived
from vsa_gym.devices.vsaut2.lever import lever_forces, spring_stiffness
from vsa_gym.devices.vsaut2.params import VsaUT2Params
from vsa_gym.devices.vsaut2.pivot import pivot_jacobian, pivot_position, sun_inertia
from vsa_gym.physics.contact import two_sided_stop
from vsa_gym.physics.integrate import exponential_rk4, rk4
from vsa_gym.physics.kernels import flatten_rows
from vsa_gym.physics.parameters import as_batch


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
        object.__setattr__(self, "_n_eff", effect_state_columns(p))  # effect-state columns (hysteresis: 0 or 1)
        # compiled path: every leaf an (m,) float64 array (m = 1 or n), one numba signature batched or not
        object.__setattr__(self, "p_rows", flatten_rows(p.as_tuple()))
        object.__setattr__(self, "d_rows", flatten_rows(derived))

    @property
    def n_effect_states(self) -> int:
        """Effect-state columns after the 10 core states (:data:`EFFECT_STATE`): 1 with spring hysteresis, else 0."""
        return self._n_eff

    @property
    def n_states(self) -> int:
        return N_STATES + self._n_eff + sum(e.n_states for e in self.extensions)

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
            from vsa_gym.devices.vsaut2.pivot import sun_angle_for

            x[:, STATE["th1"]] = p.pivot_gearbox.n * sun_angle_for(p.pivot, np.broadcast_to(q1, (n,)))
        x[:, STATE["q2"]] = q2
        x[:, STATE["th2"]] = np.asarray(q2) * p.frame_ratio
        x[:, STATE["r"]] = q2 if r is None else r
        col = N_STATES + self._n_eff  # the hysteresis state starts at 0 (no presliding deflection)
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
            col = N_STATES + self._n_eff
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
        rhs_core(x, u, tau_ext, self.params, self._d, ports, dx, pw, self._n_eff)
        pw[:, 6] += p_ext_diss
        if dz_parts:
            dx[:, N_STATES + self._n_eff:] = np.concatenate(dz_parts, axis=-1)
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
        """Magnetic + kinetic + elastic energy (J), shape ``(n,)``; with spring hysteresis, the Dahl element's
        ``h^2 phi_h / (2 M)`` too (``M = M_h + mu_h |tau_s|``)."""
        p = self.params
        m1, m2 = p.pivot_motor, p.frame_motor
        kin = self.kinematics(x)
        d = self._d
        e = 0.5 * (m1.L * x[..., 0] ** 2 + m2.L * x[..., 3] ** 2 + d.J1 * x[..., 2] ** 2 + d.J2 * x[..., 5] ** 2
                   + p.I_ad * x[..., 7] ** 2 + p.I_o * x[..., 9] ** 2)
        lev = lever_forces(p.lever, kin.q1, kin.phi, kin.q1_dot, kin.phi_dot)
        e = e + lev.energy
        e = e + 0.5 * p.belt.C_belt * kin.delta**2 - 0.5 * p.belt.C_belt * (
            dead_zone_energy(kin.delta + p.effects.b_belt, p.effects.b_eps)
            - dead_zone_energy(kin.delta - p.effects.b_belt, p.effects.b_eps))
        zero = 0.0 * x[..., 0]
        e = e + two_sided_stop(x[..., 1], zero, -STOP_MARGIN_MOTOR, d.th1_max + STOP_MARGIN_MOTOR, p.K_s1, p.D_s1,
                               STOP_EPS_MOTOR).energy
        e = e + two_sided_stop(x[..., 6], zero, -p.q2_max, p.q2_max, p.K_q2, p.D_q2, STOP_EPS_FRAME).energy
        if self._n_eff:
            M_h, h = p.effects.M_h + p.effects.mu_h * np.abs(lev.tau_phi), x[..., EFFECT_STATE["h_phi"]]
            e = e + np.where(M_h > 0.0, 0.5 * h * h * p.effects.phi_h / np.where(M_h > 0.0, M_h, 1.0), 0.0)
        col = N_STATES + self._n_eff
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

