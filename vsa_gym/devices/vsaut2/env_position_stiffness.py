"""``vsa_gym/VsaUT2-PositionStiffness-v0``: track an output position and a stiffness reference on the vsaUT-II."""

from __future__ import annotations

from typing import Any

import numba
import numpy as np

from vsa_gym.devices.vsaut2.model import STATE
from vsa_gym.devices.vsaut2.sensing_rows import K_FLOOR, N_COMMON_OBS, true_stiffness_row
from vsa_gym.devices.vsaut2.task import (
    C_DT,
    ENERGY_INFO,
    K_KB,
    K_RATE,
    MARGIN_INFO,
    OUT_NEW_SEGMENT,
    VsaUT2Task,
    common_obs_of,
    drive_all,
    energy_row,
    margins_into,
    threaded_variant,
)
from vsa_gym.envs.signals import SegmentReference, segment_value
from vsa_gym.envs.task import (
    OUT_CLIPPED,
    OUT_FAIL,
    OUT_REWARD,
    STATUS_BAD_ACTION,
    STATUS_BAD_STATE,
    ObsChannel,
    TaskEnv,
    actions_finite,
    clip_obs_row,
    failure_charge,
    failure_horizon,
    indent,
    obs_table,
)
from vsa_gym.envs.vector import TaskVectorEnv

_R = STATE["r"]  # a state column the compiled step can fold

N_SEG = 7  # columns of one SegmentReference in s["seg"] (its keys, in SegmentReference._keys order)

ENV_NAME = "VsaUT2-PositionStiffness-v0"


class PositionStiffnessTask(VsaUT2Task):
    """Batched logic of :class:`VsaUT2PositionStiffnessEnv` (its docstring documents everything)."""

    reward_terms = ("position", "stiffness", "energy", "failure")
    step_info = (*ENERGY_INFO, *MARGIN_INFO, "position_error", "log_stiffness_error", "tau_ext")
    n_signals = 3  # ref_r, ref_k, dist
    trace_names = ("r", "r_ref", "ln K", "ln K_ref", "i1", "i2", "tau_ext")
    trace_units = ("rad", "rad", "ln(N m/rad)", "ln(N m/rad)", "A", "A", "N m")
    trace_groups = ((0, 1, 6), (2, 3), (4, 5))

    def __init__(
        self,
        n: int,
        *,
        w_position: float = 1.0,
        w_stiffness: float = 1.0,
        w_energy: float = 1.0,
        position_scale: float = 0.2,
        log_stiffness_scale: float = 1.0,
        failure_penalty: float = 100.0,
        failure_rate: float | None = None,
        episode_steps: int | None = None,
        position_range: float = 0.4,
        stiffness_range: tuple[float, float] = (2.0, 300.0),
        disturbance_max: float = 0.5,
        **kwargs: Any,
    ) -> None:
        # control_dt, control_mode, params, domain_randomization, sensor_noise, regen, ...: see VsaUT2Task
        super().__init__(n, **kwargs)
        self.w = {"position": float(w_position), "stiffness": float(w_stiffness), "energy": float(w_energy)}
        self.position_scale, self.log_stiffness_scale = float(position_scale), float(log_stiffness_scale)
        self.failure_penalty = float(failure_penalty)
        self._failure_rate_arg, self.episode_steps = failure_horizon(ENV_NAME, failure_rate, episode_steps)
        self.position_range = float(position_range)
        self.stiffness_range = (float(stiffness_range[0]), float(stiffness_range[1]))
        q2_max = float(np.min(self.base_rows[0].q2_max))
        if not 0 < position_range < q2_max:
            raise ValueError(f"position_range must lie in (0, q2_max = {q2_max:.3f}) rad, got {position_range}")
        lo, hi = stiffness_range
        if not 0 < lo < hi:
            raise ValueError(f"stiffness_range must be (low, high) with 0 < low < high, got {stiffness_range}")
        self.ref_r = SegmentReference("ref_r", -position_range, position_range, freq=(0.1, 1.5))
        self.ref_k = SegmentReference("ref_k", float(np.log(lo)), float(np.log(hi)), freq=(0.1, 1.0))
        self.dist = SegmentReference("dist", -abs(disturbance_max), abs(disturbance_max) + 1e-12,
                                     kinds=("step", "ramp"), zero_prob=0.5)
        # the signals' segment columns and the current reference values in one array each (the compiled step
        # takes them as one argument); the named entries are views of their columns, written in place only
        seg = np.zeros((self.n, 3 * N_SEG))
        self.s["seg"] = seg
        for j, sig in enumerate((self.ref_r, self.ref_k, self.dist)):
            for k, key in enumerate(sig._keys):
                self.s[key] = seg[:, N_SEG * j + k]
        refs = np.zeros((self.n, 3))
        self.s["refs"] = refs
        self.s["r_ref"] = refs[:, 0]
        self.s["k_ref"] = refs[:, 1]
        self.s["tau"] = refs[:, 2]
        self.s["steps"] = np.zeros(self.n, dtype=np.int64)  # control steps taken in the episode
        self._weights = np.array([self.w["position"], self.position_scale, self.w["stiffness"],
                                  self.log_stiffness_scale, self.w["energy"], self.failure_penalty,
                                  float(self.episode_steps)])
        self._set_channels(self._common_channels() + [
            ObsChannel("r_ref", "rad", -position_range, position_range, "output position reference"),
            ObsChannel("log_K_ref", "ln(N m/rad)", float(np.log(lo)), float(np.log(hi)),
                       "stiffness reference (natural log)"),
            ObsChannel("r_err", "rad", -np.pi - position_range, np.pi + position_range, "r_ref - r_hat"),
            ObsChannel("log_K_err", "ln(N m/rad)", float(np.log(lo) - np.log(1000.0)),
                       float(np.log(hi) - np.log(K_FLOOR)), "log_K_ref - log_K_hat"),
        ])

    def failure_rate(self) -> np.ndarray:
        """Per-row charge per remaining step of a failed episode, ``(n,)`` (docstring of the env, Rewards).

        ``failure_rate`` if given, else the largest cost one step can have before a failure: the position
        error is below ``q2_max + phi_max + position_range`` (frame and deflection inside their stops, the
        reference inside its range), ``|ln K - ln K_ref|`` below ``max(ln K_hi - ln K_FLOOR, ln K_b - ln K_lo)``
        (``K_FLOOR <= K < K_b``, the belt in series), and each drive draws at most ``U_max I_max``.
        """
        if self._failure_rate_arg is not None:
            return np.full(self.n, self._failure_rate_arg)
        c = self._cols()
        lo, hi = np.log(self.stiffness_range[0]), np.log(self.stiffness_range[1])
        e_r = c["q2_max"] + c["phi_max"] + self.position_range
        e_k = np.maximum(hi - np.log(K_FLOOR), np.log(c["K_b"]) - lo)
        p_max = (c["U_max"] * c["I_max"]).sum(axis=1)
        return (self.w["position"] * (e_r / self.position_scale) ** 2
                + self.w["stiffness"] * (e_k / self.log_stiffness_scale) ** 2
                + self.w["energy"] * p_max * self.control_dt)

    def _failure_rates(self) -> np.ndarray:
        return self.failure_rate()

    def _reset_rows(self, rows: np.ndarray) -> None:
        self._sample_params(rows)
        self._reset_common(rows)
        for i in rows:
            rng = self.rngs[int(i)]
            p = self.row_params[int(i)]
            q1 = float(rng.uniform(0.1, 0.9)) * float(p.q1_max)
            q2 = float(rng.uniform(-0.5, 0.5)) * float(p.q2_max)
            self._set_initial_state(int(i), self._row_model(int(i)).initial_state(1, q1=q1, q2=q2)[0])
        for sig in (self.ref_r, self.ref_k, self.dist):
            sig.reset(self.s, rows, self.rngs)
        zero = np.zeros(len(rows))
        self.s["r_ref"][rows] = self.ref_r.value(self.s, zero, rows)
        self.s["k_ref"][rows] = self.ref_k.value(self.s, zero, rows)
        self.s["tau"][rows] = 0.0  # no disturbance at the start
        self.s["steps"][rows] = 0
        self._reset_sensors(rows)

    def _build_kernel_args(self) -> tuple[Any, ...]:
        s = self.s
        return (s["x"], self.model.p_rows, self.model.d_rows, self._row_cols(), self._cfg, self._weights,
                s["drive"], s["refs"], s["seg"], s["steps"], s["t"], self._obs_lo64, self._obs_hi64, s["obs"])

    def _after_kernel(self, out: np.ndarray) -> None:
        s = self.s
        flags = out[self._n_info + OUT_NEW_SEGMENT:]
        for j, sig in enumerate((self.ref_r, self.ref_k, self.dist)):  # the signals' order of draws
            ended = np.flatnonzero(flags[j])
            if ended.size:  # the compiled step put the ended segments' values at t_new into refs
                sig.renew(s, ended, self.rngs, s["t"], s["refs"][:, j])

    def _observe(self, rows: np.ndarray) -> np.ndarray:
        c = self._common_obs(rows)
        r_ref, k_ref = self.s["r_ref"][rows], self.s["k_ref"][rows]
        n = N_COMMON_OBS
        out = np.empty((c.shape[0], n + 4))  # the common channels, then r_ref, log_K_ref and the two errors
        out[:, :n] = c
        out[:, n], out[:, n + 1], out[:, n + 2], out[:, n + 3] = r_ref, k_ref, r_ref - c[:, 2], k_ref - c[:, 8]
        return out

    def _traces(self, rows: np.ndarray) -> np.ndarray:
        x = self.s["x"][rows]
        K = np.maximum(self.model.stiffness(self.s["x"])[rows], K_FLOOR)
        return np.stack([x[:, STATE["r"]], self.s["r_ref"][rows], np.log(K), self.s["k_ref"][rows],
                         x[:, STATE["i1"]], x[:, STATE["i2"]], self.s["tau"][rows]], axis=1)


# ---------------------------------------------------------------------------- compiled task step
@numba.njit(cache=True)
def _position_stiffness_rows(a: np.ndarray, x: np.ndarray, P: np.ndarray, D: np.ndarray, C: np.ndarray,
                             cfg: np.ndarray, w: np.ndarray, drv: np.ndarray, refs: np.ndarray, seg: np.ndarray,
                             steps: np.ndarray, t: np.ndarray, lo: np.ndarray, hi: np.ndarray, obs: np.ndarray,
                             out: np.ndarray) -> int:
    """One control step of the task for every row in one call (what ``step`` returns, up to ``info``).

    The drive and core step of all rows (:func:`~vsa_gym.devices.vsaut2.task.drive_all`), then per row: true
    stiffness, errors, energy, margins, failure, reward terms into ``out[:, i]`` (``step_info``, the reward
    terms, the ``OUT_*`` tail with one renewal flag per signal), the references and the disturbance at the new
    time (:class:`SegmentReference`), the time and the noise-free clipped observation.  ``refs``: ``s["refs"]``
    (r_ref, k_ref, tau); ``seg``: ``s["seg"]``; ``w = [w_position, position_scale, w_stiffness,
    log_stiffness_scale, w_energy, failure_penalty, episode_steps]``.  Returns ``STATUS_BAD_ACTION`` or
    ``STATUS_BAD_STATE`` (nothing changed), else the number of renewal flags set.
    """
    if not actions_finite(a):
        return STATUS_BAD_ACTION
    n = x.shape[0]
    tau = refs[:, 2].copy()  # the disturbance held over the step
    e_m = np.empty((n, 2))
    clipped = np.empty(n, dtype=np.bool_)
    if not drive_all(a, x, tau, np.ones(n, dtype=np.bool_), P, D, C, cfg, drv, e_m, clipped):
        return STATUS_BAD_STATE
    m = len(ENERGY_INFO) + len(MARGIN_INFO) + 3 + 4
    o = np.empty(N_COMMON_OBS + 4)
    flagged = 0
    for i in range(n):
        t_new = t[i] + cfg[C_DT]
        logK = np.log(max(true_stiffness_row(x, P, C[:, K_KB], i), K_FLOOR))
        e_r = x[i, _R] - refs[i, 0]
        e_k = logK - refs[i, 1]
        charged = energy_row(i, e_m, drv, cfg, out)
        fail = margins_into(x, drv, C, i, out, 6)
        steps[i] += 1
        r_pos = -w[0] * (e_r / w[1]) ** 2
        r_stf = -w[2] * (e_k / w[3]) ** 2
        r_en = -w[4] * charged
        r_fail = failure_charge(w[5], C[i, K_RATE], steps[i], w[6]) if fail else 0.0
        out[10, i], out[11, i], out[12, i] = e_r, e_k, tau[i]
        out[13, i], out[14, i], out[15, i], out[16, i] = r_pos, r_stf, r_en, r_fail
        out[m + OUT_REWARD, i] = 0.0 + r_pos + r_stf + r_en + r_fail  # the reward: the sum of the terms, in term order
        out[m + OUT_FAIL, i] = 1.0 if fail else 0.0
        out[m + OUT_CLIPPED, i] = 1.0 if clipped[i] else 0.0
        for j in range(3):
            b = N_SEG * j
            refs[i, j], ended = segment_value(seg[:, b], seg[:, b + 1], seg[:, b + 2], seg[:, b + 3], seg[:, b + 4],
                                               seg[:, b + 5], seg[:, b + 6], t_new, i)
            out[m + OUT_NEW_SEGMENT + j, i] = 1.0 if ended else 0.0
            flagged += ended
        t[i] = t_new  # the time after the step
        common_obs_of(x, P, C, drv, i, o)
        o[N_COMMON_OBS], o[N_COMMON_OBS + 1] = refs[i, 0], refs[i, 1]
        o[N_COMMON_OBS + 2], o[N_COMMON_OBS + 3] = refs[i, 0] - o[2], refs[i, 1] - o[8]
        clip_obs_row(o, lo, hi, obs, i)
    return flagged


PositionStiffnessTask._kernel = (_position_stiffness_rows, threaded_variant(_position_stiffness_rows))

_OBS_DOC = indent(obs_table(PositionStiffnessTask(1).obs_channels))


class VsaUT2PositionStiffnessEnv(TaskEnv):
    __doc__ = f"""Track an output position and an output stiffness reference with the vsaUT-II.

    ## Description
    The vsaUT-II (Groothuis et al.) sets its output stiffness by moving the pivot of a
    spring-loaded lever (pivot motor, RE-20 + GP26B + planetary straight-line
    mechanism) and its equilibrium position by turning the frame (frame motor, RE-40
    + GP42C + belt).  The output link (test bar) carries an external torque
    disturbance: random steps and ramps up to ``disturbance_max`` N m (half of the
    segments hold zero).  References are chains of random steps, ramps and sines:
    the position inside ``+-position_range`` rad, the stiffness log-uniformly inside
    ``stiffness_range`` N m/rad.  Physics: :class:`vsa_gym.devices.vsaut2.model.VsaUT2Model`.

    ## Action space
    ``Box(-1, 1, (2,), float32)``: [pivot motor, frame motor].  ``control_mode="voltage"``:
    ``u = a U_max`` (24 V); ``"current"``: ``i_ref = a I_max`` (12 A) tracked by a current-mode
    amplifier at 10 kHz (see :mod:`vsa_gym.devices.vsaut2.task`).  Finite out-of-range
    components are clipped (``info["action_clipped"]``); NaN or inf raise ``ValueError``
    naming the component, and nothing is changed.

    ## Observation space
    ``Box(low, high, (15,), float32)``, built only from sensors (values clipped to the bounds):

{_OBS_DOC}

    ## Rewards
    ``reward = position + stiffness + energy + failure`` with (true state after the step)::

        position  = -w_position  ((r - r_ref) / position_scale)^2              (position_scale = 0.2 rad)
        stiffness = -w_stiffness ((ln K - ln K_ref) / log_stiffness_scale)^2   (K: eq. 6 in series with the belt,
                                                                               floored at 0.1 N m/rad)
        energy    = -w_energy E_el                                             (J over the step)
        failure   = -(failure_penalty + failure_rate (episode_steps - k)) on a failure at step k, else 0

    A failure ends the episode, and the steps it did not take would each have cost something:
    a fixed penalty alone made failing *cheaper* than tracking to the time limit (a policy could
    end every episode after a few dozen steps on purpose).  The failure term therefore also charges
    every step left until ``episode_steps`` (default: the registered time limit, 2500 steps; the
    native vector env takes its ``max_episode_steps``) at ``failure_rate`` per step.  By default
    ``failure_rate`` is the largest cost any step can have before a failure (with the default
    arguments about 129 per step: position error at most ``q2_max + phi_max + position_range``
    = 1.6 rad -> 64, stiffness error at most ``ln(300 / 0.1)`` -> 64, both drives at ``U_max I_max``
    -> 1.2; :meth:`PositionStiffnessTask.failure_rate` computes it per row from the row's parameters),
    so a failure is never cheaper than finishing the episode, whatever the policy would have done
    in the remaining steps.  With ``gym.make(..., max_episode_steps=N)`` (a ``TimeLimit`` the
    environment cannot see) pass ``episode_steps=N`` as well: a longer limit without it leaves
    failures after step 2500 charged only ``failure_penalty``.

    ``E_el`` is the core's integrated electrical energy of both motors over the step.
    Regeneration (``regen``): ``"clip"`` (default) charges ``max(E_motor, 0)`` per motor and
    step -- the supply cannot take energy back; ``"count"`` charges the signed sum, so
    regenerated energy is credited.  ``info`` carries every term (``reward_<term>``),
    ``energy_el`` (signed), ``energy_charged``, their episode totals, and the
    constraint margins ``margin_frame_stop``, ``margin_deflection_stop`` (rad),
    ``margin_i2t`` (fraction), ``margin_pivot_stroke`` (fraction).

    ## Starting state
    At rest, pivot uniform in 10-90 % of its stroke ``q1_max``, frame and output at the
    same angle uniform in ``+-q2_max / 2``, belt unstretched, no disturbance.

    ## Episode end
    ``terminated``: frame end stop contact ``|q2| >= q2_max``, deflection end stop contact
    ``|phi| >= phi_max``, or an I^2 t trip (4 A nominal, 12 A for 2 s) -- which the drives' I^2 t foldback
    (``i2t_foldback``, ``i_foldback``: the current limit folds back from 12 A towards 3 A as the utilisation goes
    from 0.5 to 0.9, :mod:`vsa_gym.devices.vsaut2.task`) keeps from happening; ``i2t_foldback=None`` removes the
    foldback.  ``truncated``: the registry's time limit (2500 steps = 5 s at the default ``control_dt``).

    ## Arguments
    ``gym.make("vsa_gym/VsaUT2-PositionStiffness-v0", control_dt=2e-3, control_mode="voltage",
    params=VsaUT2Params(), domain_randomization=None, sensor_noise=False, regen="clip",
    render_mode=None, w_position=1.0, w_stiffness=1.0, w_energy=1.0, position_scale=0.2,
    log_stiffness_scale=1.0, failure_penalty=100.0, failure_rate=None, episode_steps=None,
    position_range=0.4, stiffness_range=(2, 300), disturbance_max=0.5, current_bandwidth_hz=1000.0,
    i_nominal=4.0, i2t_trip_s=2.0, i2t_foldback=(0.5, 0.9), i_foldback=3.0, velocity_cutoff_hz=50.0,
    integrator="rk4", parallel_rows=False)``.
    ``params`` is any (e.g. identified) :class:`VsaUT2Params` or the name of a shipped set, ``"nominal"`` or
    ``"as_measured"`` (:meth:`VsaUT2Params.as_measured`: the paper's measured hysteresis, Fig. 10 period and decay);
    ``domain_randomization`` maps dotted parameter paths to ``(low, high)`` ranges resampled on
    reset (:mod:`vsa_gym.envs.randomization`); ``sensor_noise``: ``False`` / ``True`` / scale /
    ``{{"current": sigma_A}}``.  ``control_dt`` defaults to 2 ms: the fastest mechanical mode
    (output on the belt-limited 948 N m/rad, about 47 Hz) gets > 10 samples per period and the
    electrical modes (0.1-0.3 ms) are resolved by the core's sub-steps at any rate.
    ``integrator`` (numerics, opt-in): ``"etd"`` integrates the motor currents' ``L/R`` poles
    exactly and takes 7 instead of 10 core sub-steps per ms (:class:`vsa_gym.devices.vsaut2.model.VsaUT2Model`); both
    stay within 1e-3 of the Radau reference.  ``parallel_rows`` (native vector env, 64 rows or more): the
    core's row loop on all cores (:mod:`vsa_gym.devices.vsaut2.task`); same results.

    ## Version history
    * v0: initial release.
    """

    task_cls = PositionStiffnessTask


class VsaUT2PositionStiffnessVectorEnv(TaskVectorEnv):
    """Native vector version of :class:`VsaUT2PositionStiffnessEnv` (one batched core call per step).

    Its time limit ``max_episode_steps`` is also the task's ``episode_steps`` (the horizon of the failure
    charge) unless ``episode_steps`` is given.
    """

    task_cls = PositionStiffnessTask
    time_limit_is_horizon = True
