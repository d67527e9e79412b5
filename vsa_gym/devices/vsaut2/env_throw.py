"""``vsa_gym/VsaUT2-Throw-v0``: the elastic-energy throwing benchmark on the vsaUT-II."""

from __future__ import annotations

from typing import Any

import numba
import numpy as np
from numba.extending import register_jitable

from vsa_gym.devices.vsaut2.model import STATE
from vsa_gym.devices.vsaut2.sensing_rows import K_FLOOR, N_COMMON_OBS
from vsa_gym.devices.vsaut2.task import (
    C_DT,
    D_E_CH,
    ENERGY_INFO,
    MARGIN_INFO,
    VsaUT2Task,
    common_obs_of,
    drive_all,
    energy_row,
    margins_into,
    threaded_variant,
)
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
    indent,
    obs_table,
)
from vsa_gym.envs.vector import TaskVectorEnv

_R, _R_DOT = STATE["r"], STATE["r_dot"]  # state columns the compiled step can fold


class ThrowTask(VsaUT2Task):
    """Batched logic of :class:`VsaUT2ThrowEnv` (its docstring documents everything)."""

    reward_terms = ("release", "failure", "progress")
    step_info = (*ENERGY_INFO, *MARGIN_INFO, "released", "release_speed", "drive_enabled", "margin_energy")
    bool_info = ("released", "drive_enabled")
    trace_names = ("r", "r_dot", "ln K", "E_left", "i1", "i2")
    trace_units = ("rad", "rad/s", "ln(N m/rad)", "J", "A", "A")
    trace_groups = ((0, 1), (2, 3), (4, 5))

    def __init__(
        self,
        n: int,
        *,
        release_angle: float = 0.3,
        energy_budget: float = 5.0,
        horizon_s: float = 1.0,
        initial_q1_fraction: float = 0.5,
        failure_penalty: float = 1.0,
        shaping: float = 0.0,
        shaping_gamma: float = 0.99,
        **kwargs: Any,
    ) -> None:
        # control_dt, control_mode, params, domain_randomization, sensor_noise, regen, ...: see VsaUT2Task
        super().__init__(n, **kwargs)
        if not 0.0 < release_angle < np.pi / 2:
            raise ValueError(f"release_angle must lie in (0, pi/2) rad, got {release_angle}")
        if not energy_budget > 0.0:
            raise ValueError(f"energy_budget must be > 0 J, got {energy_budget}")
        if not 0.0 <= initial_q1_fraction <= 1.0:
            raise ValueError(f"initial_q1_fraction must lie in [0, 1], got {initial_q1_fraction}")
        self.release_angle, self.energy_budget = float(release_angle), float(energy_budget)
        self.horizon_s, self.q1_frac = float(horizon_s), float(initial_q1_fraction)
        self.failure_penalty = float(failure_penalty)
        if not (np.isfinite(shaping) and shaping >= 0.0):
            raise ValueError(f"shaping must be a finite weight >= 0, got {shaping}")
        if not 0.0 < shaping_gamma <= 1.0:
            raise ValueError(f"shaping_gamma must lie in (0, 1] (the agent's discount), got {shaping_gamma}")
        self.shaping, self.shaping_gamma = float(shaping), float(shaping_gamma)
        self.s["phi"] = np.zeros(self.n)  # the shaping potential of the current state (0 at rest)
        self._set_channels(self._common_channels() + [
            ObsChannel("energy_left", "J", 0.0, self.energy_budget, "energy budget not yet drawn"),
            ObsChannel("time_left", "s", 0.0, self.horizon_s, "time until the throw window closes"),
        ])
        self._weights = np.array([self.release_angle, self.energy_budget, self.horizon_s, self.failure_penalty,
                                  self.shaping, self.shaping_gamma])


    def _reset_rows(self, rows: np.ndarray) -> None:
        self._sample_params(rows)
        self._reset_common(rows)
        for i in rows:
            p = self.row_params[int(i)]
            x0 = self._row_model(int(i)).initial_state(1, q1=self.q1_frac * float(p.q1_max))[0]
            self._set_initial_state(int(i), x0)
            self.s["phi"][i] = shaping_potential(self.s["x"][i, _R], self.s["x"][i, _R_DOT], self._weights)
        self._reset_sensors(rows)

    def _build_kernel_args(self) -> tuple[Any, ...]:
        s = self.s
        return (s["x"], self.model.p_rows, self.model.d_rows, self._row_cols(), self._cfg, self._weights,
                s["drive"], s["t"], s["phi"], self._obs_lo64, self._obs_hi64, s["obs"])

    def _observe(self, rows: np.ndarray) -> np.ndarray:
        c = self._common_obs(rows)
        left = np.maximum(self.energy_budget - self.s["e_charged"][rows], 0.0)
        t_left = np.maximum(self.horizon_s - self.s["t"][rows], 0.0)
        return np.concatenate([c, left[:, None], t_left[:, None]], axis=1)

    def _traces(self, rows: np.ndarray) -> np.ndarray:
        x = self.s["x"][rows]
        K = np.maximum(self.model.stiffness(self.s["x"])[rows], K_FLOOR)
        return np.stack([x[:, STATE["r"]], x[:, STATE["r_dot"]], np.log(K),
                         self.energy_budget - self.s["e_charged"][rows], x[:, STATE["i1"]], x[:, STATE["i2"]]],
                        axis=1)

    def draw_mechanism(self, ax: Any, i: int) -> None:
        super().draw_mechanism(ax, i)
        a = self.release_angle
        ax.plot([0, 1.35 * np.cos(a)], [0, 1.35 * np.sin(a)], color="tab:orange", lw=1, ls=":", label="release")
        ax.legend(fontsize=6, loc="upper left")


# ---------------------------------------------------------------------------- compiled task step
SHAPING_SPEED = 5.0
"""rad/s: the potential's worth of reaching the release angle (about a good throw's release speed)."""


@register_jitable
def shaping_potential(r: float, r_dot: float, w: np.ndarray) -> float:
    """The progress potential ``Phi = shaping (SHAPING_SPEED clip(r / release_angle, 0, 1) + max(r_dot, 0))``
    (rad/s): how far and how fast the output is on its way to the release."""
    return w[4] * (SHAPING_SPEED * min(max(r / w[0], 0.0), 1.0) + max(r_dot, 0.0))


@numba.njit(cache=True)
def _throw_rows(a: np.ndarray, x: np.ndarray, P: np.ndarray, D: np.ndarray, C: np.ndarray, cfg: np.ndarray,
                w: np.ndarray, drv: np.ndarray, t: np.ndarray, phi: np.ndarray, lo: np.ndarray, hi: np.ndarray,
                obs: np.ndarray, out: np.ndarray) -> int:
    """One control step of the task for every row in one call (what ``step`` returns, up to ``info``).

    The drive and core step of all rows (switched off where the budget is spent;
    :func:`~vsa_gym.devices.vsaut2.task.drive_all`), then per row: energy, release, margins, failure and the
    reward terms into ``out[:, i]`` (``step_info``, the reward terms, the ``OUT_*`` tail), the time and the
    noise-free clipped observation.  ``w = [release_angle, energy_budget, horizon_s, failure_penalty, shaping,
    shaping_gamma]``; ``phi`` the rows' shaping potentials, replaced by the new state's.
    Returns ``STATUS_BAD_ACTION`` or ``STATUS_BAD_STATE`` (nothing changed), else 0.
    """
    if not actions_finite(a):
        return STATUS_BAD_ACTION
    n = x.shape[0]
    r_before = x[:, _R].copy()
    enabled = np.empty(n, dtype=np.bool_)
    for i in range(n):
        enabled[i] = drv[i, D_E_CH] < w[1]
    e_m = np.empty((n, 2))
    clipped = np.empty(n, dtype=np.bool_)
    if not drive_all(a, x, np.zeros(n), enabled, P, D, C, cfg, drv, e_m, clipped):
        return STATUS_BAD_STATE
    m = len(ENERGY_INFO) + len(MARGIN_INFO) + 4 + 3
    o = np.empty(N_COMMON_OBS + 2)
    for i in range(n):
        energy_row(i, e_m, drv, cfg, out)
        r, r_dot = x[i, _R], x[i, _R_DOT]
        released = r_before[i] < w[0] and r >= w[0]
        fail = margins_into(x, drv, C, i, out, 6) and not released
        r_rel = max(r_dot, 0.0) if released else 0.0
        r_fail = -w[3] if fail else 0.0
        out[10, i], out[11, i] = 1.0 if released else 0.0, r_dot if released else 0.0
        out[12, i], out[13, i] = 1.0 if enabled[i] else 0.0, w[1] - drv[i, D_E_CH]
        # potential-based shaping (Ng et al. 1999): gamma Phi(s') - Phi(s), Phi = 0 once the episode ends (release,
        # failure, the window closed), so it changes no policy's ranking under the agent's discount gamma
        t_next = t[i] + cfg[C_DT]
        ended = released or fail or t_next >= w[2] - 0.5 * cfg[C_DT]
        phi_next = 0.0 if ended else shaping_potential(r, r_dot, w)
        r_prog = w[5] * phi_next - phi[i]
        phi[i] = phi_next
        out[14, i], out[15, i], out[16, i] = r_rel, r_fail, r_prog
        out[m + OUT_REWARD, i] = 0.0 + r_rel + r_fail + r_prog  # the reward: the sum of the terms, in term order
        out[m + OUT_FAIL, i] = 1.0 if released or fail else 0.0
        out[m + OUT_CLIPPED, i] = 1.0 if clipped[i] else 0.0
        t[i] = t[i] + cfg[C_DT]  # the time after the step
        common_obs_of(x, P, C, drv, i, o)
        o[N_COMMON_OBS] = max(w[1] - drv[i, D_E_CH], 0.0)
        o[N_COMMON_OBS + 1] = max(w[2] - t[i], 0.0)
        clip_obs_row(o, lo, hi, obs, i)
    return 0


ThrowTask._kernel = (_throw_rows, threaded_variant(_throw_rows))

_OBS_DOC = indent(obs_table(ThrowTask(1).obs_channels))


class VsaUT2ThrowEnv(TaskEnv):
    __doc__ = f"""Throw: the highest output speed at a release angle, in fixed time and with a fixed energy budget.

    ## Description
    The classic benchmark for variable stiffness actuators that store elastic energy
    (Haddadin et al.; Braun et al.): starting from rest, the vsaUT-II must swing its
    output link (the test bar) through the release angle ``release_angle`` (0.3 rad)
    as fast as possible.  Both motors are free: the frame can wind up and swing, and
    the stiffness may vary during the throw (pumping energy into the springs).  The
    release happens when ``r`` first crosses the release angle upward.  The time window
    is the registry's time limit (``horizon_s`` = 1 s = 500 steps at 2 ms); the energy
    budget ``energy_budget`` (5 J) caps the electrical energy drawn (counted as in
    ``regen``): once spent, both drives are switched off (0 V) for the rest of the episode.

    ## Action space
    ``Box(-1, 1, (2,), float32)``: [pivot motor, frame motor], as in
    ``VsaUT2-PositionStiffness-v0`` (voltage ``a U_max`` or current ``a I_max``); finite
    out-of-range components are clipped, NaN/inf raise ``ValueError``.

    ## Observation space
    ``Box(low, high, (13,), float32)``, from sensors (clipped to the bounds):

{_OBS_DOC}

    ## Rewards
    ``reward = release + failure + progress``: ``release = max(r_dot, 0)`` (rad/s, true output speed) on
    the release step, else 0; ``failure = -failure_penalty`` (1) on a failure step; ``progress`` (0 unless
    ``shaping > 0``) is potential-based shaping (Ng, Harada & Russell 1999) that gives a learner a signal on
    every step: ``gamma Phi(s') - Phi(s)`` with ``Phi = shaping (5 rad/s clip(r / release_angle, 0, 1) +
    max(r_dot, 0))``, ``Phi = 0`` once the episode ends and ``gamma = shaping_gamma`` (set it to the agent's
    discount).  Every episode's discounted return is then the unshaped one (``Phi = 0`` at rest), so the best
    policy is unchanged and the score stays the release speed (``info["release_speed"]``).  The energy
    enters as a budget, not as a cost; ``info`` still carries ``energy_el``, ``energy_charged``,
    their totals, ``margin_energy`` (J left), the constraint margins, ``released`` and
    ``release_speed``.

    ## Starting state
    At rest, pivot at ``initial_q1_fraction`` (0.5) of its stroke, frame and output at 0.

    ## Episode end
    ``terminated``: release (success), or a failure -- frame end stop contact, deflection end
    stop contact, I^2 t trip (kept away by the drives' I^2 t foldback, as in ``VsaUT2-PositionStiffness-v0``).
    ``truncated``: the time limit (no release within the window).

    ## Arguments
    ``control_dt`` (2 ms), ``control_mode``, ``params`` (a :class:`VsaUT2Params` or ``"nominal"`` /
    ``"as_measured"``), ``domain_randomization``, ``sensor_noise``,
    ``regen`` ("clip"), ``render_mode``, ``release_angle`` (rad), ``energy_budget`` (J), ``horizon_s``
    (s, only for the ``time_left`` observation: set it with the time limit),
    ``initial_q1_fraction``, ``failure_penalty``, ``shaping`` (0), ``shaping_gamma`` (0.99), and the drive options of
    :class:`vsa_gym.devices.vsaut2.task.VsaUT2Task`.

    ## Version history
    * v0: initial release.
    """

    task_cls = ThrowTask


class VsaUT2ThrowVectorEnv(TaskVectorEnv):
    """Native vector version of :class:`VsaUT2ThrowEnv`."""

    task_cls = ThrowTask
