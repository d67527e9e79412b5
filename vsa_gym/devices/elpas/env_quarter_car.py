"""``vsa_gym/ELPAS-QuarterCar-v0``: ride comfort of a quarter car carried by the eLPAS on an ISO 8608 road."""

from __future__ import annotations

from typing import Any

import numba
import numpy as np
from numba.extending import register_jitable

from vsa_gym.devices.elpas import model as em
from vsa_gym.devices.elpas.params import GRAVITY, ElpasParams
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
from vsa_gym.envs.sensing import add_noise
from vsa_gym.envs.task import (
    OUT_CLIPPED,
    OUT_FAIL,
    OUT_REWARD,
    STATUS_BAD_ACTION,
    STATUS_BAD_STATE,
    ObsChannel,
    TaskEnv,
    actions_finite,
    failure_charge,
    failure_horizon,
    indent,
    obs_table,
)
from vsa_gym.envs.vector import TaskVectorEnv
from vsa_gym.vehicle.comfort import wk_sos
from vsa_gym.vehicle.road import ROAD_CLASSES, road_signal

ENV_NAME = "ELPAS-QuarterCar-v0"


@numba.njit(cache=True)
def sos_step(sos: np.ndarray, x: np.ndarray, zi: np.ndarray) -> np.ndarray:
    """One sample per row through a second-order-section cascade, as ``scipy.signal.sosfilt`` computes it.

    ``sos`` ``(k, 6)`` (``a0 = 1``), ``x`` ``(n,)``, state ``zi`` ``(n, k, 2)`` updated in place (transposed
    direct form II)::

        y = b0 x + z0,   z0 <- b1 x - a1 y + z1,   z1 <- b2 x - a2 y,   x <- y   (section by section)

    Returns the filtered samples ``(n,)``.
    """
    out = np.empty(x.shape[0])
    for i in range(x.shape[0]):
        out[i] = _sos_row(sos, x[i], zi, i)
    return out


@register_jitable
def _sos_row(sos: np.ndarray, x: float, zi: np.ndarray, i: int) -> float:
    """Row ``i`` of :func:`sos_step`: one sample ``x`` through the sections, ``zi[i]`` updated in place."""
    x_cur = x
    for s in range(sos.shape[0]):
        x_new = sos[s, 0] * x_cur + zi[i, s, 0]
        zi[i, s, 0] = sos[s, 1] * x_cur - sos[s, 4] * x_new + zi[i, s, 1]
        zi[i, s, 1] = sos[s, 2] * x_cur - sos[s, 5] * x_new
        x_cur = x_new
    return x_cur


class QuarterCarTask(ElpasTask):
    """Batched logic of :class:`ElpasQuarterCarEnv` (its docstring documents everything)."""

    vehicle = True
    noise_defaults = {"current": 0.2, "force": 5.0, "accel": 0.05}
    reward_terms = ("comfort", "travel", "tyre", "energy", "failure")
    step_info = (*ENERGY_INFO, "margin_gamma_stop", "margin_i2t", "margin_travel", "margin_tyre_load",
                 "body_accel", "weighted_accel", "tyre_force", "a_w_rms", "road_height", "suspension_travel")
    trace_names = ("a_s", "a_w", "road", "travel", "F_t/F_0", "P_el")
    trace_units = ("m/s^2", "m/s^2", "m", "m", "-", "kW")
    trace_groups = ((0, 1), (2, 3), (4, 5))

    def __init__(self, n: int, *, road_class: str = "B", speed: float = 20.0, road_duration_s: float = 12.0,
                 w_comfort: float = 1.0, w_travel: float = 1.0, w_tyre: float = 1.0, w_energy: float = 1e-3,
                 accel_scale: float = 1.0, travel_soft: float = 0.8, failure_penalty: float = 100.0,
                 failure_rate: float = 0.0, episode_steps: int | None = None,
                 control_dt: float | None = 2e-3, params: ElpasParams | None = None, **kwargs: Any) -> None:
        super().__init__(n, control_dt=control_dt, params=default_task_params() if params is None else params,
                         **kwargs)
        if not isinstance(road_class, str) or road_class.upper() not in ROAD_CLASSES or len(road_class) != 1:
            raise ValueError(f"road_class must be one of {', '.join(ROAD_CLASSES)}, got {road_class!r}")
        if not np.isfinite(speed) or speed <= 0:
            raise ValueError(f"speed must be > 0 m/s, got {speed!r}")
        if not 0.0 < travel_soft < 1.0:
            raise ValueError(f"travel_soft must lie in (0, 1) (fraction of alpha_max), got {travel_soft}")
        self.road_class, self.speed = road_class.upper(), float(speed)
        self.road_steps = int(round(road_duration_s / self.control_dt))
        self.w = {"comfort": float(w_comfort), "travel": float(w_travel), "tyre": float(w_tyre),
                  "energy": float(w_energy)}
        self.accel_scale, self.travel_soft = float(accel_scale), float(travel_soft)
        self.failure_penalty = float(failure_penalty)
        rate, self.episode_steps = failure_horizon(ENV_NAME, failure_rate, episode_steps)
        self.failure_rate = float(rate)
        self._weights = np.array([self.w["comfort"], self.w["travel"], self.w["tyre"], self.w["energy"],
                                  self.accel_scale, self.travel_soft, self.failure_penalty, self.failure_rate,
                                  float(self.episode_steps)])
        self.sos = wk_sos(1.0 / self.control_dt)
        self.s["road"] = np.zeros((self.n, self.road_steps + 1))
        self.s["road_k"] = np.zeros(self.n, dtype=np.intp)
        self.s["wk_zi"] = np.zeros((self.n, self.sos.shape[0], 2))
        self.s["acc"] = np.zeros(self.n)  # sprung-mass acceleration over the last step (m/s^2)
        self.s["a_w"] = np.zeros(self.n)  # W_k-weighted acceleration
        self.s["acc_meas"] = np.zeros(self.n)
        self.s["aw_sq_sum"] = np.zeros(self.n)
        self._set_channels(self._common_channels() + [
            ObsChannel("body_accel", "m/s^2", -50.0, 50.0, "sprung-mass accelerometer (vertical, gravity removed)"),
        ])


    def _new_road(self, i: int, offset: float) -> None:
        seed = int(self.rngs[i].integers(2**62))
        self.s["road"][i] = offset + road_signal(self.road_class, self.speed, self.road_steps * self.control_dt,
                                                 self.control_dt, seed)[: self.road_steps + 1]
        self.s["road_k"][i] = 0

    def _reset_rows(self, rows: np.ndarray) -> None:
        self._sample_params(rows)
        self._reset_drive(rows)
        for i in rows:
            self._set_initial_state(int(i), em.initial_state_vehicle(self.row_params[int(i)], 1, gamma=0.0)[0])
            self._new_road(int(i), 0.0)
        for k in ("acc", "a_w", "acc_meas", "aw_sq_sum"):
            self.s[k][rows] = 0.0
        self.s["wk_zi"][rows] = 0.0
        self._reset_sensors(rows)

    def _build_kernel_args(self) -> tuple[Any, ...]:
        s = self.s
        return (s["x"], self._param_matrix(), self._cfg, self._weights, s["drive"], s["t"], s["road"], s["road_k"],
                self.sos, s["wk_zi"], s["acc"], s["acc_meas"], s["a_w"], s["aw_sq_sum"], self._obs_lo64,
                self._obs_hi64, s["obs"])

    def _after_kernel(self, out: np.ndarray, renew: bool) -> np.ndarray:
        if renew:  # drive on: a fresh stretch continuing at this height
            road_end = out[self.step_info.index("road_height")]
            for i in np.flatnonzero(out[-N_OUT_TAIL + OUT_NEW_SEGMENT]):
                self._new_road(int(i), float(road_end[i]))
        s = self.s
        if self.noise["accel"]:  # the compiled step stored the reading without noise
            s["acc_meas"][:] = self._accel_reading(self._all_rows)
        return s["acc_meas"]

    def _accel_reading(self, rows: np.ndarray) -> np.ndarray:
        return add_noise(self.s["acc"][rows], self.noise["accel"], self.rngs, rows)

    def _margins(self, rows: np.ndarray) -> dict[str, np.ndarray]:
        mg = _quarter_car_margins_of(self.s["x"], self.s["i2t"], self._param_matrix(), self._cfg,
                                     np.asarray(rows, dtype=np.intp))
        return dict(zip(MARGINS, mg.T, strict=True))

    def _observe(self, rows: np.ndarray) -> np.ndarray:
        s = self.s
        return obs_rows(s["meas"], s["vel"], s["cur"], s["force"], s["acc_meas"], 1, np.asarray(rows, dtype=np.intp))

    def _traces(self, rows: np.ndarray) -> np.ndarray:
        p = self.params
        x = self.s["x"]
        F_t = em.tyre_force_unchecked(p, x)[rows]
        F0 = ((self._col(p.car.m_s) + self._col(p.car.m_u)) * GRAVITY)[rows]
        road = self.s["road"][rows, np.minimum(self.s["road_k"][rows], self.road_steps)]
        return np.stack([self.s["acc"][rows], self.s["a_w"][rows], road, em.suspension_travel(p, x)[rows], F_t / F0,
                         self.s["p_last"][rows] / 1e3], axis=1)

    def _draw_extra(self, ax: Any, i: int, scale: float) -> None:
        x = self.s["x"][i]
        c = self.row_params[i].cone
        ys = x[em.Y_S] * scale
        ax.add_patch(_rect((-0.25, ys + 0.05), 0.5, 0.25))
        tip = np.array([np.cos(x[em.ALPHA]), ys + np.sin(x[em.ALPHA])]) * np.array([c.l * scale, 1.0])
        tip[1] = ys + np.sin(x[em.ALPHA]) * c.l * scale
        ax.plot(*tip, "o", ms=14, color="0.2", label="wheel")
        road = self.s["road"][i, min(int(self.s["road_k"][i]), self.road_steps)] * scale
        ax.plot([tip[0] - 0.3, tip[0] + 0.3], [road - 0.5, road - 0.5], color="k", lw=2, label="road")


def _rect(xy: tuple[float, float], w: float, h: float) -> Any:
    from matplotlib.patches import Rectangle

    return Rectangle(xy, w, h, color="tab:blue", alpha=0.5, label="body")


#: Parallel damper of the task's default car (N s/m): light enough that the eLPAS has to supply the body
#: damping, heavy enough to damp the wheel hop.  On class B at 20 m/s (3 seeds, full episodes) the
#: skyhook through the cascade lowers a_w from 0.455 (zero policy) to 0.422 m/s^2 with c_p = 300, but only
#: from 0.512 to 0.502 with c_p = 600; with the 1.2 kN s/m of parameters.md the damper's 4-12 Hz
#: transmission dominates a_w and no body-velocity controller moves it (docs/baselines.md).
TASK_PARALLEL_DAMPER = 300.0


def default_task_params() -> ElpasParams:
    """eLPAS parameters of the quarter-car task: the nominal set with ``car.c_p = TASK_PARALLEL_DAMPER``."""
    p = ElpasParams()
    return p.replace(car=p.car.replace(c_p=TASK_PARALLEL_DAMPER))


# ---------------------------------------------------------------------------- compiled task step
MARGINS = ("margin_gamma_stop", "margin_i2t", "margin_travel", "margin_tyre_load")


@register_jitable
def _quarter_car_margins_row(x: np.ndarray, i: int, i2t: np.ndarray, P: np.ndarray,
                             cfg: np.ndarray) -> tuple[float, float, float, float, float, float]:
    """Row ``i``'s :data:`MARGINS` (end stop, I^2 t, wishbone travel, tyre load ``F_t / F_0``), then ``F_t`` and
    the static load ``F_0``."""
    p = em.matrix_row_params(P, i)
    alpha = x[i, em.ALPHA]
    F_t = em.tyre_force_point(x[i, em.Y_S], alpha, x[i, em.Y_R], p)
    F0 = (p.car.m_s + p.car.m_u) * GRAVITY
    mg, mi = drive_margins_row(x, i, i2t, P, cfg)
    return mg, mi, p.cone.alpha_max - abs(alpha), F_t / F0, F_t, F0


@numba.njit(cache=True)
def _quarter_car_margins_of(x: np.ndarray, i2t: np.ndarray, P: np.ndarray, cfg: np.ndarray,
                            rows: np.ndarray) -> np.ndarray:
    """:data:`MARGINS` of ``rows``, ``(len(rows), 4)``."""
    out = np.empty((rows.shape[0], 4))
    for j in range(rows.shape[0]):
        r = _quarter_car_margins_row(x, rows[j], i2t, P, cfg)
        out[j, 0], out[j, 1], out[j, 2], out[j, 3] = r[0], r[1], r[2], r[3]
    return out


@numba.njit(cache=True)
def _quarter_car_row(i: int, a: np.ndarray, x: np.ndarray, P: np.ndarray, cfg: np.ndarray, w: np.ndarray,
                     drv: np.ndarray, t: np.ndarray, road: np.ndarray, road_k: np.ndarray, sos: np.ndarray,
                     zi: np.ndarray, acc_s: np.ndarray, acc_meas: np.ndarray, a_w: np.ndarray, aw_sq: np.ndarray,
                     lo: np.ndarray, hi: np.ndarray, obs: np.ndarray, out: np.ndarray) -> bool:
    """One control step of row ``i`` of the quarter-car task (road sample, physics, W_k filter, energy, margins, reward
    terms) into ``out[:, i]``; returns whether the new state is finite.

    ``w = [w_comfort, w_travel, w_tyre, w_energy, accel_scale, travel_soft, failure_penalty, failure_rate,
    episode_steps]``; rows of ``out``:
    ``step_info``, the reward terms, then the ``OUT_*`` tail (``OUT_NEW_SEGMENT``: the road stretch has ended,
    Python draws the next one); the observation without noise into ``obs[i]``; advances ``t[i]``.
    ``drv``: ``s["drive"]``.
    """
    pi_int, i2t, meas, vel = drv[:, D_PI], drv[:, D_I2T], drv[:, D_MEAS:D_MEAS + 2], drv[:, D_VEL:D_VEL + 2]
    cur, force = drv[:, D_CUR], drv[:, D_FORCE]
    road_steps = road.shape[1] - 1
    dt = cfg[C_DT]
    cmd, clipped = clip_action(a, i)
    k = road_k[i] + 1
    road_end = road[i, min(k, road_steps)]
    v_before = x[i, em.V_S]
    e_el, F, finite = drive_row(x, i, cmd, road_end, P, pi_int, i2t, meas, vel, cfg)
    cur[i], force[i] = x[i, em.CURRENT], F  # the readings without noise (Python adds it if configured)
    road_k[i] = k
    charged = energy_row(i, e_el, drv[:, D_E_EL], drv[:, D_E_CH], drv[:, D_P_LAST], cfg, out)
    acc = (x[i, em.V_S] - v_before) / dt
    aw = _sos_row(sos, acc, zi, i)  # the streaming ISO 2631-1 W_k filter of sos_step
    acc_s[i], acc_meas[i], a_w[i] = acc, acc, aw  # reading without noise (Python adds it if configured)
    aw_sq[i] += aw**2
    p = em.matrix_row_params(P, i)
    alpha = x[i, em.ALPHA]
    mg, mi, mt, load, F_t, F0 = _quarter_car_margins_row(x, i, i2t, P, cfg)
    travel_frac = abs(alpha) / p.cone.alpha_max
    fail = (mg <= 0) or (mi <= 0) or (F_t <= 0.0) or (mt <= 0)
    r_comfort = -w[0] * (aw / w[4]) ** 2
    r_travel = -w[1] * (max(travel_frac - w[5], 0.0) / (1.0 - w[5])) ** 2
    r_tyre = -w[2] * ((F_t - F0) / F0) ** 2
    r_energy = -w[3] * charged / dt
    t_new = t[i] + dt
    r_fail = failure_charge(w[6], w[7], np.rint(t_new / dt), w[8]) if fail else 0.0
    out[5, i], out[6, i], out[7, i], out[8, i] = mg, mi, mt, load
    out[9, i], out[10, i], out[11, i] = acc, aw, F_t
    out[12, i] = np.sqrt(aw_sq[i] / max(t_new / dt, 1.0))
    out[13, i], out[14, i] = road_end, p.cone.l * np.sin(alpha)
    out[15, i], out[16, i], out[17, i], out[18, i], out[19, i] = r_comfort, r_travel, r_tyre, r_energy, r_fail
    m = 20
    out[m + OUT_REWARD, i] = 0.0 + r_comfort + r_travel + r_tyre + r_energy + r_fail  # the reward: the sum of the terms
    out[m + OUT_FAIL, i] = 1.0 if fail else 0.0
    out[m + OUT_CLIPPED, i] = 1.0 if clipped else 0.0
    out[m + OUT_F, i] = F
    out[m + OUT_NEW_SEGMENT, i] = 1.0 if k >= road_steps else 0.0
    obs_clip_row(meas, vel, cur, force, acc_meas, 1, lo, hi, obs, i)
    t[i] = t_new  # the time after the step
    return finite


@numba.njit(cache=True)
def _quarter_car_rows(a: np.ndarray, x: np.ndarray, P: np.ndarray, cfg: np.ndarray, w: np.ndarray, drv: np.ndarray,
                      t: np.ndarray, road: np.ndarray, road_k: np.ndarray, sos: np.ndarray, zi: np.ndarray,
                      acc_s: np.ndarray, acc_meas: np.ndarray, a_w: np.ndarray, aw_sq: np.ndarray, lo: np.ndarray,
                      hi: np.ndarray, obs: np.ndarray, out: np.ndarray) -> int:
    """:func:`_quarter_car_row` for every row: ``STATUS_BAD_ACTION`` (nothing changed) if an action is not finite,
    ``STATUS_BAD_STATE`` if a new state is not finite, else the number of rows whose road stretch has ended."""
    if not actions_finite(a):
        return STATUS_BAD_ACTION
    ok = True
    for i in range(x.shape[0]):
        fin = _quarter_car_row(i, a, x, P, cfg, w, drv, t, road, road_k, sos, zi, acc_s, acc_meas, a_w, aw_sq, lo,
                               hi, obs, out)
        ok = ok and fin
    return n_flagged(out[-N_OUT_TAIL + OUT_NEW_SEGMENT]) if ok else STATUS_BAD_STATE


@numba.njit(cache=True, parallel=True)
def _quarter_car_rows_par(a: np.ndarray, x: np.ndarray, P: np.ndarray, cfg: np.ndarray, w: np.ndarray, drv: np.ndarray,
                          t: np.ndarray, road: np.ndarray, road_k: np.ndarray, sos: np.ndarray, zi: np.ndarray,
                          acc_s: np.ndarray, acc_meas: np.ndarray, a_w: np.ndarray, aw_sq: np.ndarray, lo: np.ndarray,
                          hi: np.ndarray, obs: np.ndarray, out: np.ndarray) -> int:
    """:func:`_quarter_car_rows` with the rows spread over the cores (rows are independent)."""
    if not actions_finite(a):
        return STATUS_BAD_ACTION
    bad = 0
    for i in numba.prange(x.shape[0]):
        if not _quarter_car_row(i, a, x, P, cfg, w, drv, t, road, road_k, sos, zi, acc_s, acc_meas, a_w, aw_sq, lo,
                                hi, obs, out):
            bad += 1
    return n_flagged(out[-N_OUT_TAIL + OUT_NEW_SEGMENT]) if bad == 0 else STATUS_BAD_STATE


QuarterCarTask._kernels = (_quarter_car_rows, _quarter_car_rows_par)


_OBS_DOC = indent(obs_table(QuarterCarTask(1).obs_channels))


class ElpasQuarterCarEnv(TaskEnv):
    __doc__ = f"""Ride comfort of a quarter car (cabin corner) suspended by the eLPAS, on an ISO 8608 road.

    ## Description
    The sprung mass (260.4 kg) hangs on the wishbone pivot; the unsprung mass (40 kg) sits
    at the wishbone tip on a unilateral tyre (200 kN/m); a light 300 N s/m damper acts in
    parallel (``TASK_PARALLEL_DAMPER``: it damps the wheel hop, the eLPAS must supply the body
    damping; other values via ``params``, see :class:`vsa_gym.devices.elpas.params.QuarterCarParams`).
    The car drives at ``speed`` (20 m/s) over a random road of ISO 8608 class ``road_class`` ("B";
    on class C this light car lifts a wheel within a second whatever the controller does)
    (:func:`vsa_gym.vehicle.road.road_signal`, fresh per episode).  The controller turns
    the eLPAS arm to shape the suspension force so as to minimise the ISO 2631-1
    W_k-weighted sprung-mass acceleration (:func:`vsa_gym.vehicle.comfort.wk_sos`, applied
    causally step by step), within the suspension travel and without losing tyre contact,
    at a small energy cost.  Physics: :mod:`vsa_gym.devices.elpas.model` (vehicle configuration).

    ## Action space
    ``Box(-1, 1, (1,), float32)``: motor voltage ``a U_max`` or current reference ``a I_max``
    (``control_mode``), as in ``ELPAS-ForceTracking-v0``.  Out-of-range values are clipped;
    NaN/inf raise ``ValueError``.

    ## Observation space
    ``Box(low, high, (7,), float32)``, from sensors (clipped to the bounds):

{_OBS_DOC}

    ## Rewards
    ``reward = comfort + travel + tyre + energy + failure``::

        comfort = -w_comfort (a_w / accel_scale)^2          a_w: W_k-filtered body acceleration (m/s^2)
        travel  = -w_travel (max(|alpha|/alpha_max - travel_soft, 0) / (1 - travel_soft))^2
        tyre    = -w_tyre ((F_t - F_0) / F_0)^2             dynamic tyre load, F_0 = (m_s + m_u) g
        energy  = -w_energy P_el                            P_el = E_el / control_dt (W), E_el from the core
        failure = -(failure_penalty + failure_rate (episode_steps - k)) on a failure at step k, else 0

    A failure ends the episode.  With the fixed penalty alone (``failure_rate`` 0, the default) ending
    the ride early can be cheaper than riding on: the passive car pays about 0.3 per step, a whole
    episode about -1500, and one PPO agent with little exploration (``log_std_init`` -2) learned to end
    all 8 held-out rides on a constraint after about 3000 steps and scored a *higher* return (-1172)
    than the skyhook (-1283) (docs/agents.md, probes).  ``failure_rate`` > 0 charges every step the
    episode skips up to ``episode_steps`` (default: the registered 5000; the native vector env takes its
    ``max_episode_steps``; with ``gym.make(..., max_episode_steps=N)`` pass ``episode_steps=N`` as well);
    1.0, more than three times what the passive car or the skyhook pay per step, closes that way out.
    It is not the default because PPO with normalised rewards trained worse with it: the lump charge of
    an early failure (up to 5000) swamps the comfort signal: three pure PPO agents (final models of the
    comparison command with ``--eval-freq 0``, recorded in docs/agents.md) rode at 0.430 to 0.463 m/s^2
    with it (one near the passive car) and at 0.412 to 0.436 without it.
    Tables report every policy's episode lengths and violations, which show a policy that ends rides
    early whatever the reward says.

    The episode mean of ``-comfort`` is the squared ISO 2631 weighted RMS (``info["a_w_rms"]``
    gives the running RMS).  Regeneration (``regen``): "clip" (default, no credit) or "count".
    ``info`` also holds ``energy_el`` (J), ``power_el`` (W), ``tyre_force`` (N),
    ``suspension_travel`` (m), ``road_height`` (m) and the margins ``margin_travel`` (rad),
    ``margin_tyre_load`` (F_t / F_0), ``margin_gamma_stop`` (rad), ``margin_i2t``.

    ## Starting state
    Static equilibrium at gamma = 0 on level road (the road ramps in over 0.5 s).

    ## Episode end
    ``terminated``: tyre lift-off (``F_t = 0``), wishbone bump stop contact (``|alpha| >=
    alpha_max``), gamma end stop contact, I^2 t trip.  ``truncated``: the time limit
    (5000 steps = 10 s at the default ``control_dt`` of 2 ms).

    ## Arguments
    ``road_class`` ("A".."H"), ``speed`` (m/s), ``road_duration_s`` (length of each generated
    stretch; the road continues seamlessly), ``control_dt`` (2e-3 s; must be < 5 ms for the
    W_k filter), ``control_mode``, ``params``, ``domain_randomization`` (e.g.
    ``{{"car.m_s": (230, 290)}}``), ``sensor_noise`` (channels ``current``, ``force``, ``accel``),
    ``regen``, ``render_mode``, ``w_comfort``, ``w_travel``, ``w_tyre``, ``w_energy``,
    ``accel_scale``, ``travel_soft``, ``failure_penalty``, ``failure_rate``, ``episode_steps`` and the drive
    options of :class:`vsa_gym.devices.elpas.task.ElpasTask` (``soft_limit``, its software travel limit, among them).

    ## Version history
    * v0: initial release (class B road, 300 N s/m parallel damper by default); the drive's software travel limit
      (``soft_limit``) on by default since 2026-11-29.
    """

    task_cls = QuarterCarTask


class ElpasQuarterCarVectorEnv(TaskVectorEnv):
    """Native vector version of :class:`ElpasQuarterCarEnv`.

    Its time limit ``max_episode_steps`` is also the task's ``episode_steps`` (the horizon of the failure
    charge) unless ``episode_steps`` is given.
    """

    task_cls = QuarterCarTask
    time_limit_is_horizon = True
