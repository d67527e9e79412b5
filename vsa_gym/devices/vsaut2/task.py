"""What both vsaUT-II environments share: drive commands, sensors, energy, failures, drawing.

Nothing here integrates physics: every step calls :meth:`VsaUT2Model.step` of the
core, and the energy terms are the core's integrated power channels
``el_pivot``/``el_frame``.

Commands (``control_mode``):

* ``"voltage"``: ``u_j = a_j U_max,j`` (V), held over the control step;
* ``"current"``: ``i_ref,j = a_j I_max,j`` (A); a current-mode amplifier law
  (:func:`vsa_gym.physics.dc_motor.current_control_voltage`: ``R i_ref + k_e w + L 2 pi f_c (i_ref - i)``,
  ``f_c = current_bandwidth_hz``) runs at 10 kHz: the core is called every 0.1 ms
  with the voltage recomputed from the current state (Fig. 9 of the paper drives the frame with a constant
  current).  The amplifier's voltage and current limits act inside the core in both modes.

Sensors (:mod:`vsa_gym.physics.sensors`): incremental encoders (2000 pulses/rev,
eq. 8) on both motor shafts, the AS5043 absolute encoder (10 bit, gain mismatch) on
the output, the drives' current measurements (optional white noise).

I^2 t protection (both drives, both control modes): as a servo amplifier does (maxon EPOS4 firmware, "I2t
current limitation"), the drive folds its current limit back when its I^2 t heating state fills up instead of
stopping the motion (:func:`vsa_gym.physics.dc_motor.foldback_current`): ``I_max`` up to the utilisation
``i2t_foldback[0]`` (default 0.5), ``i_foldback`` (default 3 A, below the nominal 4 A so the heating state drains)
from ``i2t_foldback[1]`` (0.9) on, linear in between, from the utilisation at the start of each control step.
Current mode clips the current reference to the folded limit; voltage mode clamps the voltage to ``k_e w +- R
I_lim`` around the true back-EMF (:func:`~vsa_gym.physics.dc_motor.current_limited_voltage`, the amplifier law of
the core at the folded limit, held over the step: a stall within a step can still draw up to ``I_max`` briefly,
the mean square stays limited).  ``i2t_foldback=None`` switches it off (then the trip ends the episode).

Failures (``terminated``): what would damage the actuator -- frame end stop contact ``|q2| >= q2_max``,
deflection end stop contact ``|phi| >= phi_max`` -- and an I^2 t trip of either drive (:mod:`vsa_gym.envs.sensing`;
nominal current 4 A, Table IV, peak 12 A for ``i2t_trip_s``), which the foldback keeps from happening.
Each drive's I^2 t utilisation (heating state over its trip threshold, 1 = trip) is observed
(``i2t_1``, ``i2t_2``), as servo drives report it (e.g. maxon EPOS): without it the foldback and the trip would
be a hidden state that neither a controller nor an agent could anticipate.

Step: one compiled call for all rows (the task's ``_*_rows``, built from :func:`drive_all` -- the core's
own compiled RK4/ETD step, the amplifier law, the sensing of :func:`sense_update` -- and the row
functions of the energy, margins and observation, which the reset-time methods call too); Python keeps the
noise draws, the reference segment renewals and ``info``.  This is the only implementation of a task step
(``NUMBA_DISABLE_JIT=1`` runs the same functions as plain Python for debugging); ``parallel_rows=True`` (64 rows
or more) runs the same step built by :func:`threaded_variant` around the core's threaded kernels.
"""

from __future__ import annotations

import math
import types
from collections.abc import Callable, Mapping
from typing import Any, ClassVar

import numba
import numpy as np
from numba.extending import register_jitable

from vsa_gym.devices.vsaut2.belt import belt_stiffness_at_frame
from vsa_gym.devices.vsaut2.lever import lever_ratio
from vsa_gym.devices.vsaut2.model import (
    EFFECT_STATE,
    EFFECT_STATE_SWITCHES,
    ETD_SUBSTEPS_PER_MS,
    INTEGRATORS,
    N_POWER,
    N_STATES,
    P_ROW,
    PARALLEL_MIN_ROWS,
    POWER,
    STATE,
    SUBSTEPS_PER_MS,
    VsaUT2Model,
    all_finite,
    etd_rows,
    etd_rows_parallel,
    rk4_rows,
    rk4_rows_parallel,
)
from vsa_gym.devices.vsaut2.params import AS5043Encoder, HEDL5540Encoder, VsaUT2Params
from vsa_gym.devices.vsaut2.pivot import pivot_position
from vsa_gym.devices.vsaut2.sensing_rows import (
    K_FLOOR,
    common_obs_row,
    common_obs_rows,
    margin_row,
    margin_rows,
    sense_update,
    true_stiffness,
)
from vsa_gym.envs.randomization import DomainRandomization
from vsa_gym.envs.sensing import NoiseSpec, add_noise, i2t_limit, lowpass_gain
from vsa_gym.envs.task import (
    STATUS_BAD_STATE,
    CompiledStepTask,
    ControlMode,
    ObsChannel,
    RegenPolicy,
)
from vsa_gym.physics.dc_motor import current_control_voltage, current_limited_voltage, foldback_current

CURRENT_LOOP_DT = 1e-4  # s, 10 kHz current loop in current mode

# eq. (6) of the lever and the current-mode amplifier law, made callable from the compiled step (the same
# functions, not a copy; the sensing's are registered in sensing_rows)
register_jitable(lever_ratio)
register_jitable(current_control_voltage)
# state columns (STATE) as constants the compiled sensing can fold
_I1, _TH1, _I2, _TH2, _Q2, _R = STATE["i1"], STATE["th1"], STATE["i2"], STATE["th2"], STATE["q2"], STATE["r"]
_W1, _W2, _R_DOT = STATE["w1"], STATE["w2"], STATE["r_dot"]
_EL1, _EL2 = POWER["el_pivot"], POWER["el_frame"]

# entries of the drive configuration array ``VsaUT2Task._cfg`` read by the compiled step
(C_DT, C_H, C_N_INNER, C_N_SUB, C_CURRENT_MODE, C_ETD, C_BANDWIDTH, C_I_NOM, C_V_GAIN, C_ENC,
 C_REGEN_CLIP, C_FOLD_START, C_FOLD_END, C_I_FOLD) = (0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 12, 13, 14, 15)  # C_ENC: 3 entries
N_CFG = 16
# columns of the per-row parameter matrix ``VsaUT2Task._row_cols()`` (from ``_cols`` and ``failure_rate``)
(K_U1, K_U2, K_I1, K_I2, K_TH1_MAX, K_Q2_MAX, K_PHI_MAX, K_KB, K_RATIO, K_LIM1, K_LIM2, K_RATE) = range(12)
N_K = 12
# columns of the drive bookkeeping array ``s["drive"]`` (``s["i2t"]``, ``s["meas"]``, ... are views of them)
D_I2T, D_MEAS, D_VEL, D_CUR, D_E_EL, D_E_CH = 0, 2, 5, 8, 10, 11
N_DRIVE = 12
# the info values every vsaUT-II task's compiled step writes first into ``out`` (:func:`energy_row`, ``_margins``)
ENERGY_INFO = ("energy_el", "energy_el_pivot", "energy_el_frame", "energy_charged", "energy_el_total",
               "energy_charged_total")
MARGIN_INFO = ("margin_frame_stop", "margin_deflection_stop", "margin_i2t", "margin_pivot_stroke")
# the last rows of a compiled step's ``out`` (after its info values and reward terms); then one flag row per
# renewable signal of the task (``OUT_NEW_SEGMENT + k``)
OUT_NEW_SEGMENT = 3  # after task.OUT_REWARD, OUT_FAIL, OUT_CLIPPED


class VsaUT2Task(CompiledStepTask):
    """Shared vsaUT-II machinery; subclasses add references, reward and extra observations."""

    action_names = ("pivot motor command", "frame motor command")
    default_control_dt = 2e-3
    noise_defaults: Mapping[str, float] = {"current": 0.02}  # A, drive current measurement

    def __init__(
        self,
        n: int,
        *,
        control_dt: float | None = None,
        control_mode: ControlMode = "voltage",
        params: VsaUT2Params | str | None = None,
        domain_randomization: DomainRandomization | Mapping[str, tuple[float, float]] | None = None,
        sensor_noise: NoiseSpec = False,
        regen: RegenPolicy = "clip",
        current_bandwidth_hz: float = 1000.0,
        i_nominal: float = 4.0,
        i2t_trip_s: float = 2.0,
        i2t_foldback: tuple[float, float] | None = (0.5, 0.9),
        i_foldback: float = 3.0,
        velocity_cutoff_hz: float = 50.0,
        integrator: str = "rk4",
        parallel_rows: bool = False,
    ) -> None:
        super().__init__(n, control_dt=control_dt, control_mode=control_mode, sensor_noise=sensor_noise,
                         domain_randomization=domain_randomization, regen=regen)
        base = VsaUT2Params.resolve(params)  # None, a set's name ("nominal", "as_measured") or a VsaUT2Params
        bs = base.batch_size
        if bs is not None and bs != self.n:
            raise ValueError(f"params are batched with {bs} sets but there are {self.n} environments")
        self.base_rows = [base.index(i) if bs is not None else base for i in range(self.n)]
        self.row_params = list(self.base_rows)
        if self.randomization is not None:
            self.randomization.check(base)
        if integrator not in INTEGRATORS:
            raise ValueError(f"integrator must be one of {INTEGRATORS}, got {integrator!r}")
        self.integrator = integrator  # numerics of the core (VsaUT2Model.integrator); "rk4" is the default
        self._build_model()
        self.current_bandwidth_hz = float(current_bandwidth_hz)
        self.i_nominal = float(i_nominal)
        self.i2t_trip_s = float(i2t_trip_s)
        fold = (1.0, 1.0) if i2t_foldback is None else tuple(float(v) for v in i2t_foldback)
        if len(fold) != 2 or not (0.0 <= fold[0] <= fold[1] <= 1.0):
            raise ValueError(f"i2t_foldback must be (start, end) utilisations with 0 <= start <= end <= 1, or None "
                             f"(no foldback), got {i2t_foldback}")
        if not (np.isfinite(i_foldback) and i_foldback > 0.0):
            raise ValueError(f"i_foldback must be a current > 0 A, got {i_foldback}")
        self.i2t_foldback, self.i_foldback = fold, float(i_foldback)
        self.v_gain = lowpass_gain(velocity_cutoff_hz, self.control_dt)
        self.motor_encoder = HEDL5540Encoder()
        self.output_encoder = AS5043Encoder()
        # the encoders' quantisers as numbers for the compiled sensing (step 0: encoder disabled, exact angle)
        me, oe = self.motor_encoder, self.output_encoder
        self._enc = np.array([me.resolution if me.enabled else 0.0, oe.resolution if oe.enabled else 0.0,
                              oe.gain_mismatch if oe.enabled else 0.0])
        if control_mode == "current":
            self.n_inner = max(1, int(round(self.control_dt / CURRENT_LOOP_DT)))
        else:
            self.n_inner = 1
        n_ = self.n
        # the core's state: 10 columns, plus the effect states (spring hysteresis) when the parameters, or the
        # domain randomisation of one of their switches, can turn them on (rows with the effect off keep h = 0)
        width = self.model.n_states
        if self.randomization is not None and any(k in EFFECT_STATE_SWITCHES for k in self.randomization.ranges):
            width = max(width, N_STATES + len(EFFECT_STATE))
        self.s["x"] = np.zeros((n_, width))
        # the drive's per-row bookkeeping in one array (the compiled step takes it as one argument); the named
        # entries are views of its columns, so they must be written in place, never rebound
        drv = np.zeros((n_, N_DRIVE))
        self.s["drive"] = drv
        self.s["i2t"] = drv[:, D_I2T:D_I2T + 2]
        self.s["meas"] = drv[:, D_MEAS:D_MEAS + 3]  # quantised th1, th2 (motor rad), r (rad) of the last sample
        self.s["vel"] = drv[:, D_VEL:D_VEL + 3]  # filtered speed estimates of the same
        self.s["cur"] = drv[:, D_CUR:D_CUR + 2]  # measured currents
        self.s["e_el"] = drv[:, D_E_EL]  # cumulative signed electrical energy (J)
        self.s["e_charged"] = drv[:, D_E_CH]  # cumulative energy counted by the energy term (J)
        cfg = np.zeros(N_CFG)
        cfg[C_DT], cfg[C_N_INNER] = self.control_dt, self.n_inner
        cfg[C_H] = self.control_dt / self.n_inner
        etd = integrator == "etd"
        if control_mode == "current":  # VsaUT2Model._step_valid(x, u, tau, dt / n_inner, n_sub=1) per inner step
            cfg[C_N_SUB] = 1
        else:  # the sub-step count _step_valid derives from dt
            cfg[C_N_SUB] = (max(1, math.ceil(self.control_dt / 1e-3 * ETD_SUBSTEPS_PER_MS - 1e-9)) if etd
                            else max(1, math.ceil(self.control_dt / 1e-3 * SUBSTEPS_PER_MS)))
        cfg[C_CURRENT_MODE], cfg[C_ETD] = control_mode == "current", etd
        cfg[C_BANDWIDTH], cfg[C_I_NOM], cfg[C_V_GAIN] = self.current_bandwidth_hz, self.i_nominal, self.v_gain
        cfg[C_ENC:C_ENC + 3] = self._enc
        cfg[C_REGEN_CLIP] = self.regen == "clip"
        cfg[C_FOLD_START], cfg[C_FOLD_END], cfg[C_I_FOLD] = self.i2t_foldback[0], self.i2t_foldback[1], self.i_foldback
        #: drive configuration of the compiled step (``C_*`` entries)
        self._cfg = cfg
        #: any sensor noise? (then the compiled step's noise-free observation is recomputed after the draws)
        self._noisy = self.noise["current"] != 0.0
        #: run the core's row loop on all cores (numba ``prange``) from ``PARALLEL_MIN_ROWS`` rows: the task step
        #: built around VsaUT2Model's threaded kernels (:func:`threaded_variant`).  Off by default: on
        #: this shared 2-core machine the threaded kernel cost more CPU time per step than it saved (n=1024: 23 vs
        #: 14 ms of CPU time per core step at load 8-10, like the eLPAS envs in docs/performance.md)
        self._parallel = bool(parallel_rows) and self.n >= PARALLEL_MIN_ROWS
        self._init_compiled_step()

    # ------------------------------------------------------------------ model and parameters
    def _build_model(self) -> None:
        if self.randomization is None and all(p is self.base_rows[0] for p in self.row_params):
            self.params = self.row_params[0]
        else:
            self.params = VsaUT2Params.stack(self.row_params)
        self.model = VsaUT2Model(self.params, integrator=self.integrator)
        self._cols_for: VsaUT2Params | None = None

    def _cols(self) -> dict[str, np.ndarray]:
        """Per-row parameter columns the step uses, computed once per parameter set (not every step)."""
        p = self.params
        if self._cols_for is not p:
            m1, m2 = p.pivot_motor, p.frame_motor
            self._cols_cache = {
                "U_max": np.stack([self._col(m1.U_max), self._col(m2.U_max)], axis=1),
                "I_max": np.stack([self._col(m1.I_max), self._col(m2.I_max)], axis=1),
                "th1_max": np.array(self._col(p.theta1_max)),
                "q2_max": np.array(self._col(p.q2_max)),
                "phi_max": np.array(self._col(p.lever.phi_max)),
                "n1": np.array(self._col(p.pivot_gearbox.n)),
                "ratio": np.array(self._col(p.frame_ratio)),
                "K_b": np.array(self._col(belt_stiffness_at_frame(p.belt))),
            }
            self._cols_cache["i2t_lim"] = i2t_limit(self._cols_cache["I_max"], self.i_nominal, self.i2t_trip_s)
            self._cols_for = p
        return self._cols_cache

    def _sample_params(self, rows: np.ndarray) -> None:
        if self.randomization is None:
            return
        for i in rows:
            self.row_params[int(i)] = self.randomization.sample(self.base_rows[int(i)], self.rngs[int(i)])
        self._build_model()

    def _row_model(self, i: int) -> VsaUT2Model:
        """A model of row ``i``'s parameters (for its initial state), kept while they stay the same: building
        one (derived parameters, flattened rows) cost about 80 % of a reset."""
        p = self.row_params[i]
        memo = self.__dict__.setdefault("_row_model_memo", {})
        hit = memo.get(i)
        if hit is None or hit[0] is not p:
            hit = memo[i] = (p, VsaUT2Model(p))
        return hit[1]

    def _set_initial_state(self, i: int, x_row: np.ndarray) -> None:
        """Row ``i``'s state from its row model's initial state; effect states it lacks (its parameters have the
        effect off while another row's have it on) are zero."""
        m = x_row.shape[0]
        self.s["x"][i, :m] = x_row
        self.s["x"][i, m:] = 0.0

    def _col(self, value: Any) -> np.ndarray:
        """A parameter (float or ``(n,)``) as an ``(n,)`` array."""
        return np.broadcast_to(np.asarray(value, dtype=np.float64), (self.n,))

    # ------------------------------------------------------------------ common observations
    def _common_channels(self) -> list[ObsChannel]:
        p = self.base_rows[0]
        w1 = 1.5 * p.pivot_motor.U_max / p.pivot_motor.k_e
        w2 = 1.5 * p.frame_motor.U_max / p.frame_motor.k_e
        i1 = 1.25 * p.pivot_motor.I_max
        i2 = 1.25 * p.frame_motor.I_max
        return [
            ObsChannel("q1_hat", "m", 0.0, float(2.0 * p.pivot.D_p),
                       "pivot position from the pivot motor encoder (eq. 5 on the quantised angle)"),
            ObsChannel("q2_hat", "rad", -1.0, 1.0, "frame angle from the frame motor encoder (angle / 226.9)"),
            ObsChannel("r_hat", "rad", -np.pi, np.pi, "output angle, AS5043 absolute encoder (10 bit)"),
            ObsChannel("w1_hat", "rad/s", -w1, w1, "pivot motor speed estimate (filtered encoder difference)"),
            ObsChannel("w2_hat", "rad/s", -w2, w2, "frame motor speed estimate"),
            ObsChannel("r_dot_hat", "rad/s", -50.0, 50.0, "output speed estimate (filtered encoder difference)"),
            ObsChannel("i1", "A", -i1, i1, "pivot motor current (drive measurement)"),
            ObsChannel("i2", "A", -i2, i2, "frame motor current (drive measurement)"),
            ObsChannel("log_K_hat", "ln(N m/rad)", float(np.log(K_FLOOR)), float(np.log(1000.0)),
                       "stiffness estimate: eq. 6 at (q1_hat, r_hat - q2_hat) in series with the belt"),
            ObsChannel("i2t_1", "-", 0.0, 1.0,
                       "pivot drive I^2 t utilisation: heating state / trip threshold (1 = trip)"),
            ObsChannel("i2t_2", "-", 0.0, 1.0, "frame drive I^2 t utilisation (1 = trip)"),
        ]

    def _measure(self, rows: np.ndarray) -> np.ndarray:
        """Quantised sensor angles ``(len(rows), 3)``: pivot motor, frame motor, output."""
        x = self.s["x"][rows]
        th1 = self.motor_encoder.measure(x[:, STATE["th1"]])
        th2 = self.motor_encoder.measure(x[:, STATE["th2"]])
        r = self.output_encoder.measure(x[:, STATE["r"]])
        return np.stack([th1, th2, r], axis=1)

    def _reset_sensors(self, rows: np.ndarray) -> None:
        self.s["meas"][rows] = self._measure(rows)
        self.s["vel"][rows] = 0.0
        x = self.s["x"][rows]
        self.s["cur"][rows] = add_noise(x[:, [STATE["i1"], STATE["i2"]]], self.noise["current"], self.rngs, rows)

    def _common_obs(self, rows: np.ndarray) -> np.ndarray:
        """The ``N_COMMON_OBS`` common channels of ``rows`` (compiled: eq. 5 and eq. 6 on the quantised angles)."""
        c = self._cols()
        return common_obs_rows(self.s["meas"], self.s["vel"], self.s["cur"], self.s["i2t"], c["i2t_lim"],
                                self.model.p_rows, c["K_b"], c["ratio"], np.asarray(rows, dtype=np.intp))

    def _stiffness(self) -> np.ndarray:
        """True output stiffness of every row, ``VsaUT2Model.stiffness`` (eq. 6 in series with the belt), compiled."""
        return true_stiffness(self.s["x"], self.model.p_rows, self._cols()["K_b"])

    # ------------------------------------------------------------------ failures and margins
    def _margins(self, rows: np.ndarray) -> dict[str, np.ndarray]:
        c = self._cols()
        mg = margin_rows(self.s["x"], self.s["i2t"], c["th1_max"], c["q2_max"], c["phi_max"], c["i2t_lim"],
                          np.asarray(rows, dtype=np.intp))
        return {"margin_frame_stop": mg[:, 0], "margin_deflection_stop": mg[:, 1], "margin_i2t": mg[:, 2],
                "margin_pivot_stroke": mg[:, 3]}

    # ------------------------------------------------------------------ compiled step
    #: the task's compiled steps: (serial, with the core's threaded kernels; see :func:`threaded_variant`)
    _kernel: ClassVar[tuple[Callable[..., int], Callable[..., int]] | None] = None  # in a tuple: not bound
    #: renewable signals of the task (their flags follow ``OUT_NEW_SEGMENT`` in ``out``)
    n_signals: ClassVar[int] = 0


    def _failure_rates(self) -> np.ndarray:
        """Per-row charge per remaining step of a failed episode (``K_RATE``; tasks that charge one override)."""
        return np.zeros(self.n)

    def _row_cols(self) -> np.ndarray:
        """The per-row parameter columns of the compiled step, ``(n, N_K)`` (``K_*``; from :meth:`_cols`)."""
        c = self._cols()
        C = np.empty((self.n, N_K))
        C[:, K_U1:K_U2 + 1], C[:, K_I1:K_I2 + 1] = c["U_max"], c["I_max"]
        C[:, K_TH1_MAX], C[:, K_Q2_MAX], C[:, K_PHI_MAX] = c["th1_max"], c["q2_max"], c["phi_max"]
        C[:, K_KB], C[:, K_RATIO], C[:, K_LIM1:K_LIM2 + 1] = c["K_b"], c["ratio"], c["i2t_lim"]
        C[:, K_RATE] = self._failure_rates()
        return C

    def _run_kernel(self, a: np.ndarray, out: np.ndarray) -> int:
        """Run the task's compiled step on the raw actions ``a`` ``(n, 2)``. Returns ``STATUS_BAD_ACTION``
        (nothing changed), ``STATUS_BAD_STATE`` (nothing changed) or the number of flagged signal renewals."""
        assert self._kernel is not None
        return self._kernel[self._parallel](a, *self._kernel_args(), out)

    def _after_kernel(self, out: np.ndarray) -> None:
        """Python part after the compiled step: renew the signal segments flagged in ``out`` (random draws in
        the order of the signals, after the current noise); ``s["t"]`` is already the new time."""

    def _kernel_step(self, action: Any) -> np.ndarray:
        """The compiled step up to ``info``; returns ``out`` ``(n_out, n)`` (``step_info``,
        ``reward_<term>``, then the ``OUT_*`` rows)."""
        out, status = self._compiled_call(action, OUT_NEW_SEGMENT + self.n_signals)
        if status == STATUS_BAD_STATE:
            raise FloatingPointError("vsaUT-II integration produced a non-finite state; reduce dt")
        s = self.s
        if self._noisy:  # the current readings' noise draws
            s["cur"][:] = add_noise(s["x"][:, [_I1, _I2]], self.noise["current"], self.rngs, self._all_rows)
        if status > 0:
            self._after_kernel(out)
        if status > 0 or self._noisy:  # the compiled step's observation lacks the noise or a renewed segment
            s["obs"][:] = self._clip_obs(self._observe(self._all_rows))
        if self.record_history:
            self._record(self._all_rows)
        return out

    def _reset_common(self, rows: np.ndarray) -> None:
        self.s["i2t"][rows] = 0.0
        self.s["e_el"][rows] = 0.0
        self.s["e_charged"][rows] = 0.0

    # ------------------------------------------------------------------ drawing
    def draw_mechanism(self, ax: Any, i: int) -> None:
        p = self.row_params[i]
        x = self.s["x"][i]
        q2, r = x[STATE["q2"]], x[STATE["r"]]
        q1 = float(pivot_position(p.pivot, x[STATE["th1"]] / p.pivot_gearbox.n))
        K = float(self.model.stiffness(self.s["x"])[i])
        ax.set_xlim(-1.4, 1.4)
        ax.set_ylim(-1.4, 1.4)
        for lim in (-p.q2_max, p.q2_max):
            ax.plot([0, 1.25 * np.cos(lim)], [0, 1.25 * np.sin(lim)], color="0.75", lw=0.8, ls="--")
        ax.add_patch(_circle((0, 0), 0.12, "0.6"))
        ax.plot([0, np.cos(q2)], [0, np.sin(q2)], color="0.35", lw=6, solid_capstyle="round", label="frame q2")
        ax.plot([0, 1.2 * np.cos(r)], [0, 1.2 * np.sin(r)], color="tab:blue", lw=3, label="output r")
        # lever with the pivot: the pivot slides along the frame arm (q1 / 2 D_p of the stroke)
        f = 0.2 + 0.7 * q1 / (2.0 * p.pivot.D_p)
        ax.plot([f * np.cos(q2)], [f * np.sin(q2)], "o", color="tab:red", ms=8, label="pivot q1")
        tip_f = np.array([np.cos(q2), np.sin(q2)])
        tip_o = np.array([np.cos(r), np.sin(r)])
        zz = np.linspace(0, 1, 40)
        perp = np.array([-(tip_o - tip_f)[1], (tip_o - tip_f)[0]])
        perp = perp / (np.linalg.norm(perp) + 1e-9)
        pts = tip_f[:, None] + np.outer(tip_o - tip_f, zz) + 0.04 * np.outer(perp, np.sin(zz * 12 * np.pi))
        ax.plot(pts[0], pts[1], color="tab:green", lw=1)
        ax.text(-1.35, -1.3, f"K = {K:.3g} N m/rad\nq1 = {1e3 * q1:.1f} mm", fontsize=7)
        ax.legend(fontsize=6, loc="upper left")


def _circle(xy: tuple[float, float], radius: float, color: str) -> Any:
    from matplotlib.patches import Circle

    return Circle(xy, radius, color=color)


# ---------------------------------------------------------------------------- compiled task step parts
# The drive (without the noise draws), energy and margins of a step, element by element: the core's own compiled
# step (VsaUT2Model._step_valid's kernels, called here on all rows at once), the current-mode amplifier law of
# physics.dc_motor, the sensing of sense_update; the tasks' compiled steps (vsaut2_position_stiffness,
# vsaut2_throw) add references and rewards.


@register_jitable
def drive_all(a: np.ndarray, x: np.ndarray, tau: np.ndarray, enabled: np.ndarray, P: np.ndarray, D: np.ndarray,
               C: np.ndarray, cfg: np.ndarray, drv: np.ndarray, e_m: np.ndarray, clipped: np.ndarray) -> bool:
    """One control step of the drives and the core for every row on the raw (finite) actions ``a`` ``(n, 2)``.

    Clips the actions (``clipped``: rows with a component outside ``[-1, 1]``), integrates the core (voltage
    mode: ``u = a U_max``; current mode: the amplifier law every inner step), puts the per-motor electrical
    energies into ``e_m`` ``(n, 2)``, then advances the I^2 t states, encoders and speed estimates and stores
    the noise-free currents in ``drv``.  Returns ``False`` (nothing changed) if the core's state became
    non-finite.
    """
    n = x.shape[0]
    cmd = np.empty((n, 2))
    for i in range(n):
        clipped[i] = abs(a[i, 0]) > 1.0 or abs(a[i, 1]) > 1.0
        for k in range(2):
            cmd[i, k] = min(max(a[i, k], -1.0), 1.0)
    current = cfg[C_CURRENT_MODE] != 0.0
    etd = cfg[C_ETD] != 0.0
    h, n_sub, bw = cfg[C_H], int(cfg[C_N_SUB]), cfg[C_BANDWIDTH]
    xc = x.copy()
    u = np.empty((n, 2))
    e_sum = np.zeros((n, N_POWER))
    # the amplifiers' I^2 t foldback: each drive's current limit from its utilisation at the start of the step
    lim = np.empty((n, 2))
    for i in range(n):
        for k in range(2):
            lim[i, k] = foldback_current(C[i, K_I1 + k], cfg[C_I_FOLD], drv[i, D_I2T + k] / C[i, K_LIM1 + k],
                                         cfg[C_FOLD_START], cfg[C_FOLD_END])
    for _ in range(int(cfg[C_N_INNER])):
        for i in range(n):
            if not enabled[i]:
                u[i, 0], u[i, 1] = 0.0, 0.0
            elif current:  # the current reference, within the folded limit
                p = P_ROW(P, i)
                i1 = min(max(cmd[i, 0] * C[i, K_I1], -lim[i, 0]), lim[i, 0])
                i2 = min(max(cmd[i, 1] * C[i, K_I2], -lim[i, 1]), lim[i, 1])
                u[i, 0] = current_control_voltage(p.pivot_motor, i1, xc[i, _I1], xc[i, _W1], bw)
                u[i, 1] = current_control_voltage(p.frame_motor, i2, xc[i, _I2], xc[i, _W2], bw)
            else:
                u[i, 0], u[i, 1] = cmd[i, 0] * C[i, K_U1], cmd[i, 1] * C[i, K_U2]
                if lim[i, 0] < C[i, K_I1] or lim[i, 1] < C[i, K_I2]:  # folding back: the voltage clamped to it
                    p = P_ROW(P, i)
                    u[i, 0] = current_limited_voltage(p.pivot_motor, u[i, 0], xc[i, _W1], lim[i, 0])
                    u[i, 1] = current_limited_voltage(p.frame_motor, u[i, 1], xc[i, _W2], lim[i, 1])
        # the core's serial kernels: a cached function calling the parallel ones crashes when loaded from the
        # cache; threaded_variant builds an uncached copy of the step that calls the parallel ones
        if etd:
            x_new, e = etd_rows(xc, u, tau, P, D, h, n_sub)
        else:
            x_new, e = rk4_rows(xc, u, tau, P, D, h, n_sub)
        if not all_finite(x_new):
            return False
        xc[:] = x_new
        for i in range(n):
            for j in range(e.shape[1]):
                e_sum[i, j] = e_sum[i, j] + e[i, j]
    x[:] = xc
    for i in range(n):
        e_m[i, 0], e_m[i, 1] = e_sum[i, _EL1], e_sum[i, _EL2]
    sense_update(x, drv[:, D_MEAS:D_MEAS + 3], drv[:, D_VEL:D_VEL + 3], drv[:, D_I2T:D_I2T + 2],
                  cfg[C_ENC:C_ENC + 3], cfg[C_DT], cfg[C_V_GAIN], cfg[C_I_NOM])
    for i in range(n):
        drv[i, D_CUR], drv[i, D_CUR + 1] = x[i, _I1], x[i, _I2]  # the readings without noise
    return True


@register_jitable
def energy_row(i: int, e_m: np.ndarray, drv: np.ndarray, cfg: np.ndarray, out: np.ndarray) -> float:
    """Row ``i``'s step energies into ``out[:6, i]`` (``ENERGY_INFO``), the totals in ``drv``; returns the charged
    energy."""
    e0, e1 = e_m[i, 0], e_m[i, 1]
    e = e0 + e1
    charged = max(e0, 0.0) + max(e1, 0.0) if cfg[C_REGEN_CLIP] != 0.0 else e  # energy_cost_basis
    drv[i, D_E_EL] += e
    drv[i, D_E_CH] += charged
    out[0, i], out[1, i], out[2, i], out[3, i] = e, e0, e1, charged
    out[4, i], out[5, i] = drv[i, D_E_EL], drv[i, D_E_CH]
    return charged


@register_jitable
def margins_into(x: np.ndarray, drv: np.ndarray, C: np.ndarray, i: int, out: np.ndarray, k: int) -> bool:
    """Row ``i``'s margins (``MARGIN_INFO``) into ``out[k:k + 4, i]``; returns the failure flag (frame or deflection
    end stop, I^2 t trip)."""
    mg = margin_row(x, drv[:, D_I2T:D_I2T + 2], C[:, K_TH1_MAX], C[:, K_Q2_MAX], C[:, K_PHI_MAX],
                     C[:, K_LIM1:K_LIM2 + 1], i)
    out[k, i], out[k + 1, i], out[k + 2, i], out[k + 3, i] = mg
    return mg[0] <= 0 or mg[1] <= 0 or mg[2] <= 0


@register_jitable
def common_obs_of(x: np.ndarray, P: np.ndarray, C: np.ndarray, drv: np.ndarray, i: int, o: np.ndarray) -> None:
    """Row ``i``'s common observation channels (:meth:`VsaUT2Task._common_obs`) into ``o``."""
    common_obs_row(drv[:, D_MEAS:D_MEAS + 3], drv[:, D_VEL:D_VEL + 3], drv[:, D_CUR:D_CUR + 2],
                    drv[:, D_I2T:D_I2T + 2], C[:, K_LIM1:K_LIM2 + 1], P, C[:, K_KB], C[:, K_RATIO], i, o)


def threaded_variant(kernel: Any) -> Any:
    """A task's compiled step (``numba`` dispatcher) rebuilt around the core's threaded kernels, uncached.

    The copy runs the same code (its ``py_func``) with :func:`drive_all` replaced by a copy that calls
    ``rk4_rows_parallel`` / ``etd_rows_parallel``: the rows of the core's step spread over the cores,
    everything else as in the serial step, so the two give the same numbers.  Uncached, because a cached
    function that calls the parallel kernels crashes when loaded from the cache; it compiles on first use.
    """
    drive = register_jitable(_with_globals(drive_all, "_threaded", rk4_rows=rk4_rows_parallel,
                                           etd_rows=etd_rows_parallel))
    py_func = getattr(kernel, "py_func", kernel)  # a plain function under NUMBA_DISABLE_JIT=1
    return numba.njit(cache=False)(_with_globals(py_func, "_threaded", drive_all=drive))


def _with_globals(f: Any, suffix: str, **names: Any) -> Any:
    """``f`` as a new function named ``<name><suffix>`` whose global ``names`` are replaced."""
    g = dict(f.__globals__)
    g.update(names)
    twin = types.FunctionType(f.__code__, g, f.__name__ + suffix, f.__defaults__, f.__closure__)
    twin.__qualname__ = f.__qualname__ + suffix
    return twin
