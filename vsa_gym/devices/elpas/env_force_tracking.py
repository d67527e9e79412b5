"""``vsa_gym/ELPAS-ForceTracking-v0``: the eLPAS on the paper's hydropulse rig, following a force reference."""

from __future__ import annotations

from typing import Any

import numba
import numpy as np

from vsa_gym.devices.elpas import model as em
from vsa_gym.devices.elpas.task import (
    C_DT,
    D_CUR,
    D_E_CH,
    D_E_EL,
    D_FORCE,
    D_I2T,
    D_MEAS,
    D_P_LAST,
    D_PI,
    D_VEL,
    ENERGY_INFO,
    N_OUT_TAIL,
    OUT_F,
    OUT_NEW_SEGMENT,
    ElpasTask,
    clip_action,
    drive_margins_row,
    drive_row,
    energy_row,
    n_flagged,
    obs_clip_row,
    obs_rows,
)
from vsa_gym.envs.signals import Multisine, SegmentReference, multisine_value, segment_value
from vsa_gym.envs.task import (
    OUT_CLIPPED,
    OUT_FAIL,
    OUT_REWARD,
    STATUS_BAD_ACTION,
    ObsChannel,
    TaskEnv,
    actions_finite,
    check_stop_barrier,
    failure_charge,
    failure_horizon,
    indent,
    obs_table,
    stop_barrier,
)
from vsa_gym.envs.vector import TaskVectorEnv

ENV_NAME = "ELPAS-ForceTracking-v0"


class ForceTrackingTask(ElpasTask):
    """Batched logic of :class:`ElpasForceTrackingEnv` (its docstring documents everything)."""

    reward_terms = ("force", "energy", "failure", "stop")
    step_info = (*ENERGY_INFO, "margin_gamma_stop", "margin_i2t", "force_error", "alpha")
    trace_names = ("F_act", "F_ref", "alpha", "gamma", "current", "P_el")
    trace_units = ("N", "N", "rad", "rad", "A", "kW")
    trace_groups = ((0, 1), (2, 3), (4, 5))

    def __init__(self, n: int, *, w_force: float = 1.0, w_energy: float = 1e-3, force_scale: float = 500.0,
                 force_range: tuple[float, float] = (1900.0, 3200.0), alpha_amplitude: float = np.deg2rad(15.0),
                 failure_penalty: float = 100.0, failure_rate: float = 0.0, episode_steps: int | None = None,
                 w_stop: float = 0.0, stop_width: float = 0.4,
                 prescribed: tuple[np.ndarray, np.ndarray] | None = None, **kwargs: Any) -> None:
        super().__init__(n, **kwargs)
        #: ``(F_ref, alpha)`` tables ``(n, T + 1)``, one sample per control step, that replace the drawn reference and
        #: hydropulse motion (the paper's rig experiments, :mod:`baselines.elpas_rig`); empty: drawn signals
        self.tables = np.zeros((2, self.n, 1))
        if prescribed is not None:
            f_tab, a_tab = (np.atleast_2d(np.asarray(v, dtype=np.float64)) for v in prescribed)
            if f_tab.shape != a_tab.shape or f_tab.shape[0] != self.n:
                raise ValueError(f"prescribed (F_ref, alpha) must both have shape (n, T + 1) = ({self.n}, T + 1), "
                                 f"got {f_tab.shape} and {a_tab.shape}")
            self.tables = np.ascontiguousarray(np.stack([f_tab, a_tab]))
        rate, self.episode_steps = failure_horizon(ENV_NAME, failure_rate, episode_steps)
        self.failure_rate = float(rate)
        self.w_force, self.w_energy = float(w_force), float(w_energy)
        self.force_scale, self.failure_penalty = float(force_scale), float(failure_penalty)
        self.w_stop, self.stop_width = check_stop_barrier(w_stop, stop_width)
        a_max = float(np.min(self.base_rows[0].cone.alpha_max))
        if not 0.0 <= alpha_amplitude <= a_max:
            raise ValueError(f"alpha_amplitude must lie in [0, alpha_max = {a_max:.4f}] rad, got {alpha_amplitude}")
        self.alpha_sig = Multisine("alpha", min(float(alpha_amplitude), 0.999 * a_max))
        self.ref = SegmentReference("fref", *force_range, duration=(0.3, 1.5), freq=(0.2, 5.0))
        self.alpha_sig.alloc(self.s, self.n)
        self.ref.alloc(self.s, self.n)
        self.s["f_ref"] = np.zeros(self.n)
        lo, hi = force_range
        self._weights = np.array([self.w_force, self.force_scale, self.w_energy, self.failure_penalty,
                                  self.failure_rate, float(self.episode_steps), float(prescribed is not None),
                                  self.w_stop, self.stop_width])
        self._set_channels(self._common_channels() + [
            ObsChannel("force_ref", "N", float(lo), float(hi), "force reference"),
            ObsChannel("force_err", "N", float(lo) - 6000.0, float(hi), "force_ref - force"),
        ])


    def _reset_rows(self, rows: np.ndarray) -> None:
        self._sample_params(rows)
        self._reset_drive(rows)
        for i in rows:
            rng = self.rngs[int(i)]
            g = float(rng.uniform(-0.5, 0.5))
            self._set_initial_state(int(i), em.initial_state_rig(self.row_params[int(i)], 1, gamma=g, alpha=0.0)[0])
        self.alpha_sig.reset(self.s, rows, self.rngs)
        self.ref.reset(self.s, rows, self.rngs)
        self.s["f_ref"][rows] = self.ref.value(self.s, np.zeros(len(rows)), rows)
        self._reset_sensors(rows)

    def _build_kernel_args(self) -> tuple[Any, ...]:
        s, ms, rf = self.s, self.alpha_sig.prefix, self.ref.prefix
        return (s["x"], self._param_matrix(), self._cfg, self._weights, s["drive"], s["t"], s[f"{ms}_A"],
                s[f"{ms}_w"], s[f"{ms}_phi"], s[f"{ms}_sphi"], s[f"{rf}_kind"], s[f"{rf}_t0"], s[f"{rf}_T"],
                s[f"{rf}_v0"], s[f"{rf}_v1"], s[f"{rf}_A"], s[f"{rf}_f"], s["f_ref"], self.tables, self._obs_lo64,
                self._obs_hi64, s["obs"])

    def _after_kernel(self, out: np.ndarray, renew: bool) -> np.ndarray:
        if renew:  # the compiled step put the ended segments' values at t_new into f_ref
            s = self.s
            ended = np.flatnonzero(out[-N_OUT_TAIL + OUT_NEW_SEGMENT])
            self.ref.renew(s, ended, self.rngs, s["t"], s["f_ref"])  # t: already t_new
        return self.s["f_ref"]

    def _observe(self, rows: np.ndarray) -> np.ndarray:
        s = self.s
        return obs_rows(s["meas"], s["vel"], s["cur"], s["force"], s["f_ref"], 2, np.asarray(rows, dtype=np.intp))

    def _margins(self, rows: np.ndarray) -> dict[str, np.ndarray]:
        return self._drive_margins(rows)

    def _traces(self, rows: np.ndarray) -> np.ndarray:
        x = self.s["x"][rows]
        F = em.actuator_force_of(self.params, self.s["x"])[rows]
        P = self.s["p_last"][rows]
        return np.stack([F, self.s["f_ref"][rows], x[:, em.ALPHA], x[:, em.GAMMA], x[:, em.CURRENT], P / 1e3], axis=1)

    def _draw_extra(self, ax: Any, i: int, scale: float) -> None:
        x = self.s["x"][i]
        c = self.row_params[i].cone
        tip = np.array([np.cos(x[em.ALPHA]), np.sin(x[em.ALPHA])]) * c.l * scale
        ax.plot([tip[0], tip[0]], [tip[1], -0.8], color="tab:purple", lw=4, label="hydropulse")


# ---------------------------------------------------------------------------- compiled task step
@numba.njit(cache=True)
def _force_tracking_row(i: int, a: np.ndarray, x: np.ndarray, P: np.ndarray, cfg: np.ndarray, w: np.ndarray,
                        drv: np.ndarray, t: np.ndarray, ms_A: np.ndarray, ms_w: np.ndarray, ms_phi: np.ndarray,
                        ms_sphi: np.ndarray, kind: np.ndarray, t0: np.ndarray, T: np.ndarray, v0: np.ndarray,
                        v1: np.ndarray, A: np.ndarray, f: np.ndarray, f_ref: np.ndarray, tables: np.ndarray,
                        lo: np.ndarray, hi: np.ndarray, obs: np.ndarray, out: np.ndarray) -> None:
    """One control step of row ``i`` of the force-tracking task: alpha at the end of the step (:class:`Multisine`,
    or the prescribed table), physics, energy, margins and reward terms into ``out[:, i]``, then the reference at
    the new time (:class:`SegmentReference`, or the table; ``out[OUT_NEW_SEGMENT]`` flags the rows whose segment
    has ended) and the observation without noise into ``obs[i]``; advances ``t[i]``.

    ``drv``: ``s["drive"]``; ``w = [w_force, force_scale, w_energy, failure_penalty, failure_rate,
    episode_steps, prescribed, w_stop, stop_width]``; ``tables``: ``(2, n, T + 1)`` prescribed ``F_ref`` and
    alpha per control step (read when ``w[6]`` is set); rows of ``out``: ``step_info``, the reward terms, then
    the ``OUT_*`` tail.
    """
    pi_int, i2t, meas, vel = drv[:, D_PI], drv[:, D_I2T], drv[:, D_MEAS:D_MEAS + 2], drv[:, D_VEL:D_VEL + 2]
    cur, force = drv[:, D_CUR], drv[:, D_FORCE]
    dt = cfg[C_DT]
    t_new = t[i] + dt
    cmd, clipped = clip_action(a, i)
    prescribed = w[6] != 0.0
    k_new = min(int(np.rint(t_new / dt)), tables.shape[2] - 1)
    alpha_end = tables[1, i, k_new] if prescribed else multisine_value(ms_A, ms_w, ms_phi, ms_sphi, t_new, i)
    e_el, F, _ = drive_row(x, i, cmd, alpha_end, P, pi_int, i2t, meas, vel, cfg)
    cur[i], force[i] = x[i, em.CURRENT], F  # the readings without noise (Python adds it if configured)
    charged = energy_row(i, e_el, drv[:, D_E_EL], drv[:, D_E_CH], drv[:, D_P_LAST], cfg, out)
    mg, mi = drive_margins_row(x, i, i2t, P, cfg)
    err = F - f_ref[i]
    fail = (mg <= 0) or (mi <= 0)
    r_force = -w[0] * (err / w[1]) ** 2
    r_energy = -w[2] * charged / dt
    r_fail = failure_charge(w[3], w[4], np.rint(t_new / dt), w[5]) if fail else 0.0
    r_stop = stop_barrier(mg, w[7], w[8])
    out[5, i], out[6, i], out[7, i], out[8, i] = mg, mi, err, x[i, em.ALPHA]
    out[9, i], out[10, i], out[11, i], out[12, i] = r_force, r_energy, r_fail, r_stop
    m = 13
    out[m + OUT_REWARD, i] = 0.0 + r_force + r_energy + r_fail + r_stop  # the reward: the sum of the terms
    out[m + OUT_FAIL, i] = 1.0 if fail else 0.0
    out[m + OUT_CLIPPED, i] = 1.0 if clipped else 0.0
    out[m + OUT_F, i] = F
    if prescribed:
        f_ref[i], ended = tables[0, i, k_new], False
    else:
        f_ref[i], ended = segment_value(kind, t0, T, v0, v1, A, f, t_new, i)
    out[m + OUT_NEW_SEGMENT, i] = 1.0 if ended else 0.0
    obs_clip_row(meas, vel, cur, force, f_ref, 2, lo, hi, obs, i)
    t[i] = t_new  # the time after the step


@numba.njit(cache=True)
def _force_tracking_rows(a: np.ndarray, x: np.ndarray, P: np.ndarray, cfg: np.ndarray, w: np.ndarray, drv: np.ndarray,
                         t: np.ndarray, ms_A: np.ndarray, ms_w: np.ndarray, ms_phi: np.ndarray, ms_sphi: np.ndarray,
                         kind: np.ndarray, t0: np.ndarray, T: np.ndarray, v0: np.ndarray, v1: np.ndarray, A: np.ndarray,
                         f: np.ndarray, f_ref: np.ndarray, tables: np.ndarray, lo: np.ndarray, hi: np.ndarray,
                         obs: np.ndarray, out: np.ndarray) -> int:
    """:func:`_force_tracking_row` for every row: ``STATUS_BAD_ACTION`` (nothing changed) if an action is not
    finite, else the number of rows whose reference segment has ended."""
    if not actions_finite(a):
        return STATUS_BAD_ACTION
    for i in range(x.shape[0]):
        _force_tracking_row(i, a, x, P, cfg, w, drv, t, ms_A, ms_w, ms_phi, ms_sphi, kind, t0, T, v0, v1, A, f, f_ref,
                            tables, lo, hi, obs, out)
    return n_flagged(out[-N_OUT_TAIL + OUT_NEW_SEGMENT])


@numba.njit(cache=True, parallel=True)
def _force_tracking_rows_par(a: np.ndarray, x: np.ndarray, P: np.ndarray, cfg: np.ndarray, w: np.ndarray,
                             drv: np.ndarray, t: np.ndarray, ms_A: np.ndarray, ms_w: np.ndarray, ms_phi: np.ndarray,
                             ms_sphi: np.ndarray, kind: np.ndarray, t0: np.ndarray, T: np.ndarray, v0: np.ndarray,
                             v1: np.ndarray, A: np.ndarray, f: np.ndarray, f_ref: np.ndarray, tables: np.ndarray,
                             lo: np.ndarray, hi: np.ndarray, obs: np.ndarray, out: np.ndarray) -> int:
    """:func:`_force_tracking_rows` with the rows spread over the cores (rows are independent)."""
    if not actions_finite(a):
        return STATUS_BAD_ACTION
    for i in numba.prange(x.shape[0]):
        _force_tracking_row(i, a, x, P, cfg, w, drv, t, ms_A, ms_w, ms_phi, ms_sphi, kind, t0, T, v0, v1, A, f, f_ref,
                            tables, lo, hi, obs, out)
    return n_flagged(out[-N_OUT_TAIL + OUT_NEW_SEGMENT])


ForceTrackingTask._kernels = (_force_tracking_rows, _force_tracking_rows_par)


_OBS_DOC = indent(obs_table(ForceTrackingTask(1).obs_channels))


class ElpasForceTrackingEnv(TaskEnv):
    __doc__ = f"""Force tracking on the eLPAS hydropulse rig (paper Sec. 5).

    ## Description
    The eLPAS (electromechanical low-power active suspension) sets the force of a fixed
    spring on the wishbone by turning the spring's anchor arm (angle gamma) on a cone:
    at alpha = 0 the spring exerts no moment on the arm, so holding a force costs no
    energy.  On the rig the wishbone angle alpha(t) is imposed by a hydropulse: a
    random-phase multisine of a few sines plus filtered noise, bounded by
    ``alpha_amplitude`` (15 deg).  The actuator must follow a force reference (random steps,
    ramps and sines in ``force_range`` = 1900-3200 N).  Physics: :mod:`vsa_gym.devices.elpas.model`
    (rig configuration).

    ## Action space
    ``Box(-1, 1, (1,), float32)``: motor voltage ``a U_max`` (42 V) or, with
    ``control_mode="current"``, current reference ``a I_max`` (75 A) tracked by the paper's PI
    current loop at 10 kHz (:mod:`vsa_gym.devices.elpas.task`).  Finite out-of-range values are
    clipped; NaN/inf raise ``ValueError``.

    ## Observation space
    ``Box(low, high, (8,), float32)``, from sensors (clipped to the bounds):

{_OBS_DOC}

    ## Rewards
    ``reward = force + energy + failure + stop``::

        force   = -w_force ((F_act - F_ref) / force_scale)^2          (force_scale = 500 N)
        energy  = -w_energy P_el                                        (w_energy = 1e-3 per W)
        failure = -(failure_penalty + failure_rate (episode_steps - k)) on a failure at step k, else 0
        stop    = -w_stop max(0, 1 - margin_gamma_stop / stop_width)^2   (w_stop = 0: off; stop_width = 0.4 rad)

    ``stop`` is a training aid, off by default (the scored reward has no such term): it prices the approach
    to the gamma end stop from ``stop_width`` before contact, inside a ``gamma``-0.99 learner's horizon of
    about 100 steps, where the failure itself may lie several hundred steps ahead (an agent that keeps
    turning the arm while the force does not follow, at negative alpha, reaches the stop that way;
    docs/agents.md).  0.4 rad leaves the arm free up to 67 deg, where ``F_act(gamma, 0)`` already passes
    the top of ``force_range``.

    A failure ends the episode.  ``failure_rate`` > 0 also charges every step it skips, up to
    ``episode_steps`` (default: the registered 5000; the native vector env takes its ``max_episode_steps``;
    with ``gym.make(..., max_episode_steps=N)`` pass ``episode_steps=N`` as well), so that ending an
    episode on a constraint cannot be the cheap way out of tracking (2.0, about twice what the zero action
    pays per step on the table's 8 held-out episodes, does that).  The default is 0 (the fixed penalty
    alone): PPO agents trained with 2.0 (final models of the comparison command with ``--eval-freq 0``,
    recorded in docs/agents.md) tracked worse on the same 8 held-out episodes (242 N mean, 4 of 24
    episodes ended on a constraint) than with 0 (212 N, 2 of 24): the lump
    charge of an early failure swamps the normalised tracking reward.  No agent was seen to end episodes
    on purpose here (see ``ELPAS-QuarterCar-v0`` for one that did).

    ``P_el = E_el / control_dt`` is the mean electrical power over the step, ``E_el`` the
    core's integral of ``u_eff i``.  Regenerated energy (``regen``): ``"clip"`` (default) --
    negative ``E_el`` counts as 0, the supply cannot absorb it; ``"count"`` -- it is credited at
    face value.  ``info``: ``reward_*``, ``energy_el`` (J, signed), ``energy_charged``, totals,
    ``power_el`` (W), ``force_error`` (N), ``margin_gamma_stop`` (rad), ``margin_i2t`` (fraction).

    ## Starting state
    At rest, gamma uniform in +-0.5 rad, alpha = 0, no current, relaxed friction bristles.

    ## Episode end
    ``terminated``: gamma end stop contact (+-90 deg) or I^2 t trip.  ``truncated``: the time
    limit (5000 steps = 5 s at the default ``control_dt`` of 1 ms).  The drive's software travel limit
    (``soft_limit``, 80 deg; :func:`vsa_gym.devices.elpas.task.soft_limit_command`) brakes the arm before the
    end stop, as the paper's cascade does by limiting its angle reference.

    ## Arguments
    ``control_dt`` (1e-3 s), ``control_mode`` ("voltage" | "current"), ``params``
    (:class:`vsa_gym.devices.elpas.params.ElpasParams`, e.g. identified), ``domain_randomization``
    (``{{"friction.F_c": (0.15, 0.3), ...}}``), ``sensor_noise`` (False | True | scale |
    ``{{"current": A, "force": N}}``), ``regen``, ``render_mode``, ``w_force``, ``w_energy``,
    ``force_scale``, ``force_range``, ``alpha_amplitude``, ``failure_penalty``, ``failure_rate``,
    ``episode_steps``, ``w_stop``, ``stop_width`` (rad), ``current_loop``
    (:class:`~vsa_gym.devices.elpas.task.ElpasCurrentLoop`), ``i_nominal``, ``i2t_trip_s``,
    ``velocity_cutoff_hz``, ``soft_limit`` (rad, None: off), ``soft_limit_decel`` (rad/s^2), ``parallel_rows``
    (vector env: the compiled step's row loop on all cores from 64 rows; off by default, see docs/performance.md).

    ## Version history
    * v0: initial release; the drive's software travel limit on by default since 2026-11-29.
    """

    task_cls = ForceTrackingTask


class ElpasForceTrackingVectorEnv(TaskVectorEnv):
    """Native vector version of :class:`ElpasForceTrackingEnv`; its time limit ``max_episode_steps`` is also the
    task's ``episode_steps`` (the horizon of the failure charge) unless ``episode_steps`` is given."""

    task_cls = ForceTrackingTask
    time_limit_is_horizon = True
