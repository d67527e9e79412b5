"""What both eLPAS environments share: drive commands, the paper's current loop, sensors, energy, failures.

Physics: :func:`vsa_gym.devices.elpas.model.step_rig` / :func:`~vsa_gym.devices.elpas.model.step_vehicle`;
the energy terms are the core's integrated ``P_EL`` channel.

Commands (``control_mode``):

* ``"voltage"``: ``u = a U_max`` (42 V) held over the control step;
* ``"current"``: ``I_ref = a I_max`` (75 A) tracked by the paper's motor controller
  (eqs. 10-13, Table 2): a PI controller on the torque error ``K_T (I_ref - I)`` with
  ``P_m = 0.1 V/(N m)``, ``I_m = 50 V/(N m s)``, the integrator clamped to ``+-28 V``
  (anti-windup), plus the resistance feed-forward ``R I_ref``.  It runs at 10 kHz:
  the core is stepped every 0.1 ms (``numerics.dt = 1e-4``, one RK4 sub-step) with
  the imposed input (alpha or road height) interpolated linearly.

Sensors: motor encoder (2000 pulses/rev, eq. 8 of the vsaUT-II paper's model of a
quadrature encoder) read as ``gamma = theta_m / N``; a 12-bit absolute encoder on the
wishbone (alpha) [proposed: the paper does not name its sensor]; the drive's current
measurement; the force sensor between wishbone and hydropulse/body (``F_act``);
optional white noise on current and force (``sensor_noise``).

Drive protection (``soft_limit``): the paper's cascade keeps the arm inside its range by limiting the angle
reference to [-90, 90] deg (Sec. 4); an agent that commands the motor directly has no angle loop, so the drive
keeps a software travel limit of its own, as servo drives do (CiA 402 software position limit; the "safely-limited
position" function of IEC 61800-5-2): from the encoder angle and the drive's speed estimate it limits the command
towards the nearer end stop so that the arm, braking at ``soft_limit_decel``, comes to rest at ``soft_limit``
(:func:`soft_limit_command`).  Commands away from the stop, and everything short of the braking curve, pass
unchanged.  ``soft_limit=None`` switches it off.

Failures: gamma end-stop contact ``|gamma| >= gamma_max`` (90 deg), I^2 t trip of the
drive (nominal 25 A [proposed], peak 75 A for 2 s).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any, ClassVar

import numba
import numpy as np
from numba.extending import register_jitable

from vsa_gym.devices.elpas import model as em
from vsa_gym.devices.elpas.cone import spring_unchecked
from vsa_gym.devices.elpas.current_loop import ElpasCurrentLoop, core_substeps, current_loop_row, loop_steps
from vsa_gym.devices.elpas.params import ElpasAlphaEncoder, ElpasMotorEncoder, ElpasParams, NumericsParams
from vsa_gym.envs.randomization import DomainRandomization
from vsa_gym.envs.sensing import NoiseSpec, add_noise, i2t_limit, i2t_update, lowpass_gain, update_velocity
from vsa_gym.envs.task import (
    STATUS_BAD_STATE,
    CompiledStepTask,
    ControlMode,
    ObsChannel,
    RegenPolicy,
    clip_obs_row,
)
from vsa_gym.physics.sensors import absolute_encoder_angle, floor_quantize

# entries of the drive configuration array ``ElpasTask._cfg`` read by the compiled step
(C_DT, C_H, C_N_INNER, C_N_SUB, C_CURRENT_MODE, C_P_M, C_I_M, C_I_M_MAX, C_I_NOM, C_V_GAIN, C_ENC_MOTOR,
 C_ENC_ALPHA, C_ENC_GM, C_I2T_TRIP, C_REGEN_CLIP, C_VEHICLE, C_SOFT_LIM, C_SOFT_DEC) = range(18)
N_CFG = 18
#: the software travel limit's defaults: 80 deg (10 deg before the end stops; the top of the force-tracking
#: reference range needs less than 67 deg) and a braking deceleration of 100 rad/s^2 (a sixth of what I_max gives
#: the bare arm, K_T I_max |N| / J_r = 600 rad/s^2, leaving the rest for the spring's moment)
SOFT_LIMIT_DEFAULT = 1.3962634015954636  # rad (80 deg)
SOFT_LIMIT_DECEL_DEFAULT = 100.0  # rad/s^2
#: the braking curve turns linear within ``2 decel tau^2`` of the limit (time constant tau, s), so that it has a
#: finite slope there; the command reaches full reverse when the speed exceeds the curve by ``SOFT_LIMIT_BAND``
SOFT_LIMIT_TAU = 0.02  # s
SOFT_LIMIT_BAND = 0.5  # rad/s
# columns of the drive bookkeeping array ``s["drive"]`` (``s["pi_int"]``, ... are views of them)
D_PI, D_I2T, D_MEAS, D_VEL, D_CUR, D_FORCE, D_E_EL, D_E_CH, D_P_LAST = 0, 1, 2, 4, 6, 7, 8, 9, 10
N_DRIVE = 11
# the last rows of a compiled step's ``out`` (after its info values and reward terms)
OUT_F, OUT_NEW_SEGMENT = 3, 4  # after task.OUT_REWARD, OUT_FAIL, OUT_CLIPPED
N_OUT_TAIL = 5
PARALLEL_MIN_ROWS = 64  # rows from which the compiled steps run their row loop on all cores


def stack_elpas(rows: list[ElpasParams], numerics: NumericsParams) -> ElpasParams:
    """One batched :class:`ElpasParams` from per-row sets (numerics stay scalar)."""
    groups = ("motor", "friction", "drive", "cone", "car", "effects")
    kw = {g: type(getattr(rows[0], g)).stack([getattr(r, g) for r in rows]) for g in groups}
    return ElpasParams(**kw, numerics=numerics)


class ElpasTask(CompiledStepTask):
    """Shared eLPAS machinery; subclasses choose the configuration (rig or vehicle)."""

    action_names = ("motor command",)
    default_control_dt = 1e-3
    noise_defaults: Mapping[str, float] = {"current": 0.2, "force": 5.0}  # A, N
    vehicle: bool = False

    def __init__(
        self,
        n: int,
        *,
        control_dt: float | None = None,
        control_mode: ControlMode = "voltage",
        params: ElpasParams | None = None,
        domain_randomization: DomainRandomization | Mapping[str, tuple[float, float]] | None = None,
        sensor_noise: NoiseSpec = False,
        regen: RegenPolicy = "clip",
        current_loop: ElpasCurrentLoop | None = None,
        i_nominal: float = 25.0,
        i2t_trip_s: float = 2.0,
        velocity_cutoff_hz: float = 50.0,
        soft_limit: float | None = SOFT_LIMIT_DEFAULT,
        soft_limit_decel: float = SOFT_LIMIT_DECEL_DEFAULT,
        parallel_rows: bool = False,
    ) -> None:
        super().__init__(n, control_dt=control_dt, control_mode=control_mode, sensor_noise=sensor_noise,
                         domain_randomization=domain_randomization, regen=regen)
        base = ElpasParams() if params is None else params
        if not isinstance(base, ElpasParams):
            raise TypeError(f"params must be an ElpasParams, got {type(base).__name__}")
        bs = base.batch_size
        if bs is not None and bs != self.n:
            raise ValueError(f"params are batched with {bs} sets but there are {self.n} environments")
        if self.randomization is not None:
            self.randomization.check(base)
            if any(k.startswith("numerics.") for k in self.randomization.ranges):
                raise ValueError("domain_randomization: numerics (dt, n_sub) cannot be randomised")
        if control_mode == "current":  # the 10 kHz loop's steps (the identification replay runs the same)
            self.n_inner, h, n_sub = loop_steps(self.control_dt)
        else:
            self.n_inner, h = 1, self.control_dt
            n_sub = core_substeps(h)
        self.numerics = NumericsParams(dt=h, n_sub=float(n_sub))
        self.base_rows = [base.index(i) if bs is not None else base for i in range(self.n)]
        self.row_params = list(self.base_rows)
        self._build_params()
        self.loop = ElpasCurrentLoop() if current_loop is None else current_loop
        self.i_nominal, self.i2t_trip_s = float(i_nominal), float(i2t_trip_s)
        gmax = float(np.min(np.asarray(base.cone.gamma_max)))
        if soft_limit is not None and not (np.isfinite(soft_limit) and 0.0 < soft_limit < gmax):
            raise ValueError(f"soft_limit must be an angle in (0, gamma_max = {gmax:.4f}) rad, or None (off), "
                             f"got {soft_limit}")
        if not (np.isfinite(soft_limit_decel) and soft_limit_decel > 0.0):
            raise ValueError(f"soft_limit_decel must be a deceleration > 0 rad/s^2, got {soft_limit_decel}")
        self.soft_limit = None if soft_limit is None else float(soft_limit)
        self.soft_limit_decel = float(soft_limit_decel)
        self.v_gain = lowpass_gain(velocity_cutoff_hz, self.control_dt)
        self.motor_encoder = ElpasMotorEncoder()
        self.alpha_encoder = ElpasAlphaEncoder()
        n_ = self.n
        # the core's state: the base columns, plus the effect states (arm hysteresis) when the parameters, or the
        # domain randomisation of one of their switches, can turn them on (rows with the effect off keep h = 0)
        width = (em.N_VEHICLE if self.vehicle else em.N_RIG) + em.effect_state_columns(base)
        if self.randomization is not None and any(k in em.EFFECT_STATE_SWITCHES for k in self.randomization.ranges):
            width = max(width, em.effect_column(self.vehicle) + len(em.EFFECT_STATES))
        self.s["x"] = np.zeros((n_, width))
        # the drive's per-row bookkeeping in one array (the compiled steps take it as one argument); the named
        # entries are views of its columns, so they must be written in place, never rebound
        drv = np.zeros((n_, N_DRIVE))
        self.s["drive"] = drv
        self.s["pi_int"] = drv[:, D_PI]
        self.s["i2t"] = drv[:, D_I2T]
        self.s["meas"] = drv[:, D_MEAS:D_MEAS + 2]  # gamma, alpha (quantised)
        self.s["vel"] = drv[:, D_VEL:D_VEL + 2]
        self.s["cur"] = drv[:, D_CUR]
        self.s["force"] = drv[:, D_FORCE]
        self.s["e_el"] = drv[:, D_E_EL]
        self.s["e_charged"] = drv[:, D_E_CH]
        self.s["p_last"] = drv[:, D_P_LAST]  # mean electrical power of the last step (W), for the traces
        me, ae = self.motor_encoder, self.alpha_encoder
        cfg = np.zeros(N_CFG)
        cfg[C_DT], cfg[C_H], cfg[C_N_INNER] = self.control_dt, h, self.n_inner
        cfg[C_N_SUB] = em.substep_count(self.params)
        cfg[C_CURRENT_MODE] = control_mode == "current"
        cfg[C_P_M], cfg[C_I_M], cfg[C_I_M_MAX] = self.loop.P_m, self.loop.I_m, self.loop.I_m_max
        cfg[C_I_NOM], cfg[C_V_GAIN], cfg[C_I2T_TRIP] = self.i_nominal, self.v_gain, self.i2t_trip_s
        # the encoders' quantisers as numbers for the compiled sensing (step 0: encoder disabled, exact angle)
        cfg[C_ENC_MOTOR] = me.resolution if me.enabled else 0.0
        cfg[C_ENC_ALPHA] = ae.resolution if ae.enabled else 0.0
        cfg[C_ENC_GM] = ae.gain_mismatch if ae.enabled else 0.0
        cfg[C_REGEN_CLIP], cfg[C_VEHICLE] = self.regen == "clip", self.vehicle
        cfg[C_SOFT_LIM] = 0.0 if self.soft_limit is None else self.soft_limit  # 0: off
        cfg[C_SOFT_DEC] = self.soft_limit_decel
        #: drive configuration of the compiled step (``C_*`` entries)
        self._cfg = cfg
        self._init_compiled_step()
        #: any sensor noise? (then the compiled step's noise-free observation is recomputed after the draws)
        self._noisy = any(v != 0.0 for v in self.noise.values())
        self._analog_noisy = bool(self.noise["current"] or self.noise["force"])
        self._P_memo: tuple[Any, np.ndarray] | None = None
        #: run the compiled step's row loop on all cores (numba ``prange``) from ``PARALLEL_MIN_ROWS`` rows.
        #: Off by default: on this shared 2-core machine the OpenMP workers' waiting cost far more than the
        #: second core gave (vector ELPAS-ForceTracking-v0, load average 9-11: n=64 4.3k instead of 51k
        #: env-steps/s, n=1024 33k instead of 54k; docs/performance.md)
        self._parallel = bool(parallel_rows) and self.n >= PARALLEL_MIN_ROWS

    # ------------------------------------------------------------------ parameters
    def _build_params(self) -> None:
        if self.randomization is None and all(p is self.base_rows[0] for p in self.row_params):
            self.params = self.row_params[0].replace(numerics=self.numerics)
        else:
            self.params = stack_elpas(self.row_params, self.numerics)

    def _sample_params(self, rows: np.ndarray) -> None:
        if self.randomization is None:
            return
        for i in rows:
            self.row_params[int(i)] = self.randomization.sample(self.base_rows[int(i)], self.rngs[int(i)])
        self._build_params()

    def _set_initial_state(self, i: int, x_row: np.ndarray) -> None:
        """Row ``i``'s state from its own parameters' initial state; effect states it lacks (its parameters have
        the effect off while another row's have it on) are zero."""
        m = x_row.shape[0]
        self.s["x"][i, :m] = x_row
        self.s["x"][i, m:] = 0.0

    def _col(self, value: Any) -> np.ndarray:
        """A parameter (float or ``(n,)``) as an ``(n,)`` array, memoised per parameter set (not rebuilt every step)."""
        memo = self.__dict__.get("_col_memo")
        if memo is None or memo[0] is not self.params:
            memo = (self.params, {})
            self._col_memo = memo
        hit = memo[1].get(id(value))
        if hit is None or hit[0] is not value:  # the value is kept alive in the memo, so its id is not reused
            hit = (value, np.broadcast_to(np.asarray(value, dtype=np.float64), (self.n,)))
            memo[1][id(value)] = hit
        return hit[1]

    # ------------------------------------------------------------------ sensors
    def _common_channels(self) -> list[ObsChannel]:
        p = self.base_rows[0]
        g = float(p.cone.gamma_max) + 0.1
        a = float(p.cone.alpha_max) + 0.05
        wg = 1.5 * p.motor.U_max / p.motor.k_e / abs(p.drive.N)
        im = 1.25 * p.motor.I_max
        return [
            ObsChannel("gamma_hat", "rad", -g, g, "arm angle from the motor encoder (theta_m / N)"),
            ObsChannel("gamma_dot_hat", "rad/s", -wg, wg, "arm speed estimate (filtered encoder difference)"),
            ObsChannel("alpha_hat", "rad", -a, a, "wishbone angle, 12-bit absolute encoder"),
            ObsChannel("alpha_dot_hat", "rad/s", -20.0, 20.0, "wishbone speed estimate"),
            ObsChannel("current", "A", -im, im, "motor current (drive measurement)"),
            ObsChannel("force", "N", 0.0, 6000.0, "force sensor: actuator force F_act"),
        ]

    def _measure(self, rows: np.ndarray) -> np.ndarray:
        x = self.s["x"][rows]
        N = self._col(self.params.drive.N)[rows]
        gam = self.motor_encoder.measure(N * x[:, em.GAMMA]) / N
        alp = self.alpha_encoder.measure(x[:, em.ALPHA])
        return np.stack([gam, alp], axis=1)

    def _read_analog(self, rows: np.ndarray, F_true: np.ndarray | None = None) -> None:
        """Current and force readings of ``rows`` (noise drawn row by row); ``F_true``: the true ``F_act`` of
        every row at the current state if already known."""
        if F_true is None:
            F_true = em.actuator_force_of(self.params, self.s["x"])
        self._F_true = F_true  # true F_act of every row at the current state
        F = self._F_true[rows]
        self.s["cur"][rows] = add_noise(self.s["x"][rows, em.CURRENT], self.noise["current"], self.rngs, rows)
        self.s["force"][rows] = add_noise(F, self.noise["force"], self.rngs, rows)

    def _param_matrix(self) -> np.ndarray:
        """The parameters of every row for the compiled step (``model.params_matrix``, cached on the set)."""
        memo = self._P_memo
        if memo is None or memo[0] is not self.params:
            memo = self._P_memo = (self.params, em.params_matrix(self.params, self.n))
        return memo[1]

    def _reset_sensors(self, rows: np.ndarray) -> None:
        self.s["meas"][rows] = self._measure(rows)
        self.s["vel"][rows] = 0.0
        self._read_analog(rows)

    def _check_finite(self, finite: bool) -> None:
        if not finite and self.vehicle:
            raise ValueError("step_vehicle: the state became non-finite (check inputs and parameters)")

    # ------------------------------------------------------------------ compiled step
    #: the task's compiled steps: (row loop, row loop over all cores)
    _kernels: ClassVar[tuple[Callable[..., int], Callable[..., int]] | None] = None

    def _run_kernel(self, a: np.ndarray, out: np.ndarray) -> int:
        """Run the task's compiled step on the raw actions ``a`` ``(n, 1)``. Returns ``STATUS_BAD_ACTION``
        (nothing changed), ``STATUS_BAD_STATE`` or the number of rows flagged in ``out[OUT_NEW_SEGMENT]``."""
        assert self._kernels is not None
        return self._kernels[self._parallel](a, *self._kernel_args(), out)

    def _after_kernel(self, out: np.ndarray, renew: bool) -> np.ndarray:
        """Python part after the compiled step (the random draws after the noise; ``renew``: some row is
        flagged in ``out[OUT_NEW_SEGMENT]``); returns the observation channels after the common ones
        (``obs_rows``'s ``extra``)."""
        raise NotImplementedError

    def _kernel_step(self, action: Any) -> np.ndarray:
        """The compiled step up to ``info``; returns ``out`` ``(n_out, n)`` (see ``OUT_*``)."""
        out, status = self._compiled_call(action, N_OUT_TAIL)
        self._check_finite(status != STATUS_BAD_STATE)
        if self._analog_noisy:
            self._read_analog(self._all_rows, out[-N_OUT_TAIL + OUT_F])
        extra = self._after_kernel(out, status > 0)  # the compiled step has advanced s["t"]
        s = self.s
        if status > 0 or self._noisy:  # the compiled step's observation lacks the noise or a renewed segment
            _obs_clip_into(s["meas"], s["vel"], s["cur"], s["force"], extra, len(self._channels) - 6,
                           self._obs_lo64, self._obs_hi64, s["obs"])
        if self.record_history:
            self._record(self._all_rows)
        return out

    def _drive_margins(self, rows: np.ndarray) -> dict[str, np.ndarray]:
        """``margin_gamma_stop`` and ``margin_i2t`` of ``rows`` (the compiled step's :func:`drive_margins_row`)."""
        mg = _drive_margins_of(self.s["x"], self.s["i2t"], self._param_matrix(), self._cfg,
                               np.asarray(rows, dtype=np.intp))
        return {"margin_gamma_stop": mg[:, 0], "margin_i2t": mg[:, 1]}

    def _reset_drive(self, rows: np.ndarray) -> None:
        for k in ("pi_int", "i2t", "e_el", "e_charged", "p_last"):
            self.s[k][rows] = 0.0

    # ------------------------------------------------------------------ drawing
    def draw_mechanism(self, ax: Any, i: int) -> None:
        p = self.row_params[i]
        x = self.s["x"][i]
        gam, alp = x[em.GAMMA], x[em.ALPHA]
        c = p.cone
        y0 = x[em.Y_S] if self.vehicle else 0.0
        s = 1.0 / (c.a + 0.15)
        ax.set_xlim(-0.3, 1.5)
        ax.set_ylim(-0.9, 0.9)
        tip = np.array([np.cos(alp), np.sin(alp)]) * c.l * s
        base = np.array([0.0, y0 * s])
        ax.plot([base[0], base[0] + tip[0]], [base[1], base[1] + tip[1]], color="0.3", lw=5, label="wishbone")
        mot = base + np.array([np.cos(alp), np.sin(alp)]) * c.a * s
        up = np.array([-np.sin(alp), np.cos(alp)])
        apex = mot + up * c.h * s
        arm = mot + np.array([np.cos(alp), np.sin(alp)]) * c.r * s * np.sin(gam) + up * 0.0
        ax.plot([mot[0], apex[0]], [mot[1], apex[1]], color="0.6", lw=1, ls="--")
        ax.plot([mot[0], arm[0]], [mot[1], arm[1]], color="tab:red", lw=3, label=f"arm gamma={np.rad2deg(gam):.0f} deg")
        ax.plot([apex[0], arm[0]], [apex[1], arm[1]], color="tab:green", lw=2, label="spring")
        ax.plot(*mot, "o", color="k", ms=6)
        F = float(em.actuator_force_of(self.params, self.s["x"])[i])
        ax.text(-0.25, -0.85, f"F_act = {F:.0f} N\nalpha = {np.rad2deg(alp):.1f} deg", fontsize=7)
        self._draw_extra(ax, i, s)
        ax.legend(fontsize=6, loc="upper left")

    def _draw_extra(self, ax: Any, i: int, scale: float) -> None:
        """Configuration-specific drawing (hydropulse or body and road); subclasses add to the picture."""
        del ax, i, scale


# ---------------------------------------------------------------------------- compiled per-step drive
# One row's drive, core step, sensors and I^2 t state, element by element: the core's compiled
# per-row step (model.advance_row, the same equations as step_rig/step_vehicle), the PI current loop with the
# operations of its numpy form, sensing.i2t_update / update_velocity, and the encoders' quantisers of
# physics.sensors (IncrementalEncoder / AbsoluteEncoder.measure; step 0: encoder disabled, exact angle).
@register_jitable
def drive_row(x: np.ndarray, i: int, cmd: float, second_end: float, P: np.ndarray, pi_int: np.ndarray,
               i2t: np.ndarray, meas: np.ndarray, vel: np.ndarray, cfg: np.ndarray) -> tuple[float, float, bool]:
    """Advance row ``i`` one control step in place (``x``, ``pi_int``, ``i2t``, ``meas``, ``vel``).

    ``cmd``: the clipped action; ``second_end``: alpha (rig) or road height (vehicle) at the end of the step.
    Returns ``(E_el, F_act, finite)``: the electrical energy (J), the true actuator force at the new state and
    whether the new state is finite.
    """
    p = em.matrix_row_params(P, i)
    vehicle = cfg[C_VEHICLE] != 0.0
    col = em.Y_R if vehicle else em.ALPHA
    dt, h = cfg[C_DT], cfg[C_H]
    n_inner, n_sub = int(cfg[C_N_INNER]), int(cfg[C_N_SUB])
    xr = x[i]
    if cfg[C_SOFT_LIM] > 0.0:
        sgn = 1.0 if p.drive.N > 0.0 else -1.0  # the arm turns with the motor's sign over N
        cmd = sgn * soft_limit_command(sgn * cmd, meas[i, 0], vel[i, 0], cfg[C_SOFT_LIM], cfg[C_SOFT_DEC])
    if cfg[C_CURRENT_MODE] == 0.0:
        x_new = np.empty(xr.shape[0])
        e = np.empty(em.N_POWER)
        u = cmd * p.motor.U_max
        em.advance_row(xr, u, (second_end - xr[col]) / h, p, h, n_sub, vehicle, x_new, e)
        x_new[col] = second_end
        xr[:] = x_new
        e_el = e[em.P_EL]
    else:
        m = p.motor
        pi_int[i], e_el = current_loop_row(xr, cmd * m.I_max, pi_int[i], xr[col], second_end, p, h, n_inner, n_sub,
                                           vehicle, m.k_t, m.R, cfg[C_P_M], cfg[C_I_M], cfg[C_I_M_MAX])
    finite = True
    for j in range(xr.shape[0]):
        finite = finite and np.isfinite(xr[j])
    i2t[i] = i2t_update(i2t[i], xr[em.CURRENT] ** 2, cfg[C_I_NOM], dt)
    N = p.drive.N
    m0 = floor_quantize(N * xr[em.GAMMA], cfg[C_ENC_MOTOR]) / N
    a = absolute_encoder_angle(xr[em.ALPHA], cfg[C_ENC_ALPHA], cfg[C_ENC_GM])
    vel[i, 0] = update_velocity(meas[i, 0], m0, vel[i, 0], dt, cfg[C_V_GAIN])
    vel[i, 1] = update_velocity(meas[i, 1], a, vel[i, 1], dt, cfg[C_V_GAIN])
    meas[i, 0], meas[i, 1] = m0, a
    F = spring_unchecked(p.cone, xr[em.GAMMA], xr[em.ALPHA]).F_act
    return e_el, F, finite


@register_jitable
def soft_limit_command(cmd: float, gamma: float, speed: float, limit: float, decel: float) -> float:
    """The drive's software travel limit: the command ``cmd`` (in [-1, 1], positive turning the arm towards
    positive ``gamma``: the motor command times the sign of the reduction ``N``) as the drive applies it.

    ``gamma``, ``speed``: the drive's encoder angle (rad) and speed estimate (rad/s); ``limit``: the limit angle
    (rad, both sides); ``decel``: the braking deceleration it plans with (rad/s^2).  With ``s`` the side of the
    nearer stop, ``d = limit - s gamma`` the distance left and ``v = s speed`` the speed towards it, the allowed
    speed is the braking curve ``v_a = sign(d) min(sqrt(2 decel |d|), |d| / SOFT_LIMIT_TAU)`` (negative beyond the
    limit: back inside), and the command towards the stop is capped at ``(v_a - v) / SOFT_LIMIT_BAND`` (full reverse
    at the latest ``SOFT_LIMIT_BAND`` above the curve).  Commands away from the stop pass unchanged.
    """
    s = 1.0 if gamma >= 0.0 else -1.0
    d = limit - s * gamma
    allowed = min(np.sqrt(2.0 * decel * abs(d)), abs(d) / SOFT_LIMIT_TAU)
    if d < 0.0:
        allowed = -allowed
    cap = (allowed - s * speed) / SOFT_LIMIT_BAND
    if s * cmd > cap:
        return s * max(cap, -1.0)
    return cmd


@register_jitable
def energy_row(i: int, e_el: float, e_tot: np.ndarray, e_ch_tot: np.ndarray, p_last: np.ndarray,
                cfg: np.ndarray, out: np.ndarray) -> float:
    """:meth:`ElpasTask._energy_info` for row ``i`` into ``out[:5, i]`` (``ENERGY_INFO``); returns the charged
    energy."""
    charged = max(e_el, 0.0) if cfg[C_REGEN_CLIP] != 0.0 else e_el  # energy_cost_basis of one motor
    e_tot[i] += e_el
    e_ch_tot[i] += charged
    dt = cfg[C_DT]
    p_last[i] = e_el / dt
    out[0, i], out[1, i], out[2, i], out[3, i], out[4, i] = e_el, charged, e_tot[i], e_ch_tot[i], e_el / dt
    return charged


ENERGY_INFO = ("energy_el", "energy_charged", "energy_el_total", "energy_charged_total", "power_el")


@register_jitable
def drive_margins_row(x: np.ndarray, i: int, i2t: np.ndarray, P: np.ndarray, cfg: np.ndarray) -> tuple[float, float]:
    """``(margin_gamma_stop, margin_i2t)`` of row ``i`` (:meth:`ElpasTask._drive_margins`)."""
    p = em.matrix_row_params(P, i)
    lim = i2t_limit(p.motor.I_max, cfg[C_I_NOM], cfg[C_I2T_TRIP])
    return p.cone.gamma_max - abs(x[i, em.GAMMA]), 1.0 - i2t[i] / lim


@numba.njit(cache=True)
def _drive_margins_of(x: np.ndarray, i2t: np.ndarray, P: np.ndarray, cfg: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """:func:`drive_margins_row` of ``rows``, ``(len(rows), 2)``."""
    out = np.empty((rows.shape[0], 2))
    for j in range(rows.shape[0]):
        out[j, 0], out[j, 1] = drive_margins_row(x, rows[j], i2t, P, cfg)
    return out


@numba.njit(cache=True)
def obs_rows(meas: np.ndarray, vel: np.ndarray, cur: np.ndarray, force: np.ndarray, extra: np.ndarray,
              n_extra: int, rows: np.ndarray) -> np.ndarray:
    """Observation rows ``(len(rows), 6 + n_extra)`` (float64, unclipped)."""
    out = np.empty((rows.shape[0], 6 + n_extra))
    for j in range(rows.shape[0]):
        _obs_row(meas, vel, cur, force, extra, n_extra, rows[j], out[j])
    return out


@register_jitable
def _obs_row(meas: np.ndarray, vel: np.ndarray, cur: np.ndarray, force: np.ndarray, extra: np.ndarray,
             n_extra: int, i: int, o: np.ndarray) -> None:
    """Observation of row ``i`` into ``o``: the common channels, then ``extra[i]`` and, with ``n_extra = 2``,
    ``extra[i] - force[i]`` (force tracking: reference and error; quarter car: accelerometer)."""
    o[0], o[1], o[2], o[3] = meas[i, 0], vel[i, 0], meas[i, 1], vel[i, 1]
    o[4], o[5], o[6] = cur[i], force[i], extra[i]
    if n_extra == 2:
        o[7] = extra[i] - force[i]


@numba.njit(cache=True)
def _obs_clip_into(meas: np.ndarray, vel: np.ndarray, cur: np.ndarray, force: np.ndarray, extra: np.ndarray,
                   n_extra: int, lo: np.ndarray, hi: np.ndarray, obs: np.ndarray) -> None:
    """Every row's observation, clipped to ``[lo, hi]`` in float64 and stored as float32 into ``obs``
    (``BatchedTask._clip_obs(_observe(rows))``)."""
    for i in range(obs.shape[0]):
        obs_clip_row(meas, vel, cur, force, extra, n_extra, lo, hi, obs, i)


@register_jitable
def clip_action(a: np.ndarray, i: int) -> tuple[float, bool]:
    """Row ``i``'s command clipped to ``[-1, 1]`` and whether it was outside (``task._clip_actions``)."""
    v = a[i, 0]
    return min(max(v, -1.0), 1.0), abs(v) > 1.0


@register_jitable
def n_flagged(flags: np.ndarray) -> int:
    """Number of nonzero entries (rows flagged by a compiled step)."""
    k = 0
    for v in flags:
        k += v != 0.0
    return k


@register_jitable
def obs_clip_row(meas: np.ndarray, vel: np.ndarray, cur: np.ndarray, force: np.ndarray, extra: np.ndarray,
                  n_extra: int, lo: np.ndarray, hi: np.ndarray, obs: np.ndarray, i: int) -> None:
    """Row ``i`` of :func:`_obs_clip_into`."""
    o = np.empty(6 + n_extra)
    _obs_row(meas, vel, cur, force, extra, n_extra, i, o)
    clip_obs_row(o, lo, hi, obs, i)
