"""Quarter-car baselines on ``ELPAS-QuarterCar-v0`` and the ideal-force skyhook reference.

Policies (observation -> current reference, ``control_mode="current"``; both reuse the
paper's cascade :class:`baselines.elpas_cascade.ElpasCascade` and the environment's current loop):

* :class:`PassiveHold` -- the passive suspension: the eLPAS held at ``gamma = 0`` by the angle
  loop (eq. 14); the car rides on the eLPAS's effective stiffness and the parallel damper.
* :class:`SkyhookCascade` -- skyhook damping realised through the eLPAS cascade:
  ``F_ref = m_s g - c_sky v_hat``, where ``v_hat`` is the body speed estimated from the body
  accelerometer (``body_accel``) by a leaky integrator (high-pass at ``hp_hz``) and a low-pass at ``lp_hz``
  (1.5 Hz: the skyhook acts on the body mode, not on wheel-hop motion it would only lag behind); ``F_ref`` then
  goes through the paper's 10 Hz low-pass, 2-D lookup and angle loop.

Reference (not a policy, not subject to the actuator): :func:`ideal_skyhook_reference` --
the **ideal-force skyhook**, an upper reference that ignores the actuator: a linear quarter
car with the eLPAS's effective stiffness at the static equilibrium, the parallel damper, the
tyre and an ideal force ``-c_sky v_s`` between body and wheel (no motor, no current or speed
limits, no lag), driven by the environment's own road realisation for the seed.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from scipy import signal

from baselines.elpas_cascade import ElpasCascade, ElpasCascadeConfig
from vsa_gym.devices.elpas.cone import effective_stiffness
from vsa_gym.devices.elpas.model import equilibrium_alpha
from vsa_gym.devices.elpas.params import GRAVITY, ElpasParams
from vsa_gym.vehicle.comfort import weighted_rms

QUARTER_CAR_ID = "vsa_gym/ELPAS-QuarterCar-v0"
QC_OBS = ("gamma_hat", "gamma_dot_hat", "alpha_hat", "alpha_dot_hat", "current", "force", "body_accel")


class PassiveHold(ElpasCascade):
    """The eLPAS held at gamma = 0 by the paper's angle loop (the passive suspension)."""

    def force_reference(self, obs: np.ndarray) -> np.ndarray:
        return np.zeros(obs.shape[0])

    def gamma_reference(self, f_ref: np.ndarray, obs: np.ndarray) -> np.ndarray:
        return np.zeros(obs.shape[0])


@dataclasses.dataclass(frozen=True)
class SkyhookConfig:
    c_sky: float = 1000.0  # N s/m, skyhook damping (larger values cost energy and W_k comfort, see docs)
    hp_hz: float = 0.3  # high-pass of the accelerometer integration (leaky integrator)
    lp_hz: float = 1.5  # first-order low-pass on the speed estimate, aimed at the body mode (0: off)


class SkyhookCascade(ElpasCascade):
    """Skyhook force reference through the eLPAS cascade (module docstring)."""

    def __init__(self, sky: SkyhookConfig | None = None, config: ElpasCascadeConfig | None = None,
                 params: ElpasParams | None = None, obs_names: Sequence[str] = QC_OBS) -> None:
        self.sky = SkyhookConfig() if sky is None else sky
        super().__init__(config, params, obs_names)
        if "body_accel" not in self.idx:
            raise ValueError("SkyhookCascade needs the body_accel observation")
        self.F_static = float(self.params.car.m_s) * GRAVITY
        self._leak = float(np.exp(-2.0 * np.pi * self.sky.hp_hz * self.config.dt))
        self._lpv = 1.0 - float(np.exp(-2.0 * np.pi * self.sky.lp_hz * self.config.dt)) if self.sky.lp_hz > 0 else 1.0

    def reset(self) -> None:
        super().reset()
        self.v_hat = np.zeros(0)
        self.v_f = np.zeros(0)

    def force_reference(self, obs: np.ndarray) -> np.ndarray:
        if self.v_hat.shape[0] != obs.shape[0]:
            self.v_hat = np.zeros(obs.shape[0])
            self.v_f = np.zeros(obs.shape[0])
        acc = obs[:, self.idx["body_accel"]].astype(np.float64)
        self.v_hat = self._leak * self.v_hat + acc * self.config.dt
        self.v_f = self.v_f + self._lpv * (self.v_hat - self.v_f)
        return self.F_static - self.sky.c_sky * self.v_f


def _factory(cls: type[ElpasCascade], **kw: Any):  # noqa: ANN202
    def make(env) -> ElpasCascade:  # noqa: ANN001
        task = env.unwrapped.task
        cfg = ElpasCascadeConfig(dt=float(task.control_dt))
        return cls(config=cfg, params=task.base_rows[0], obs_names=[c.name for c in task.obs_channels], **kw)

    return make


def passive_factory():  # noqa: ANN201
    """``policy_factory(env)`` of :class:`PassiveHold`."""
    return _factory(PassiveHold)


def skyhook_factory(sky: SkyhookConfig | None = None):  # noqa: ANN201
    """``policy_factory(env)`` of :class:`SkyhookCascade`."""
    return _factory(SkyhookCascade, sky=sky)


# ----------------------------------------------------------------------------- ideal-force reference
def linear_quarter_car(p: ElpasParams, c_sky: float) -> signal.StateSpace:
    """Linear quarter car about the static equilibrium with an ideal skyhook force ``-c_sky v_s``.

    States ``[y_s, v_s, y_u, v_u]``, input road height, outputs ``[a_s, y_u - y_s, F_t]``.
    Suspension stiffness: the eLPAS's effective stiffness ``dF_act/d(l sin alpha)`` at
    ``(gamma = 0, alpha_eq)``; the wishbone inertia enters as ``J_w / l^2`` on the wheel.
    """
    car, c = p.car, p.cone
    a_eq = float(equilibrium_alpha(p, 0.0))
    k_s = float(effective_stiffness(c, 0.0, a_eq))
    m_s, m_u = float(car.m_s), float(car.m_u) + float(car.J_w) / float(c.l) ** 2
    k_t, c_p = float(car.k_t), float(car.c_p)
    A = np.array([
        [0, 1, 0, 0],
        [-k_s / m_s, -(c_p + c_sky) / m_s, k_s / m_s, c_p / m_s],
        [0, 0, 0, 1],
        [k_s / m_u, (c_p + c_sky) / m_u, -(k_s + k_t) / m_u, -c_p / m_u],
    ])
    B = np.array([[0.0], [0.0], [0.0], [k_t / m_u]])
    C = np.vstack([A[1], [-1, 0, 1, 0], [0, 0, -k_t, 0]])
    D = np.array([[0.0], [0.0], [k_t]])
    return signal.StateSpace(A, B, C, D)


def env_roads(seeds: Sequence[int], steps: int,
              env_kwargs: dict[str, Any] | None = None) -> tuple[np.ndarray, float, ElpasParams]:
    """The road heights the quarter-car environment uses for each seed, ``(len(seeds), steps + 1)``, dt,
    and the environment's (unrandomised) parameters.

    Read from the environment after ``reset(seed)`` (the reference must see the same road and car).
    """
    env = gym.make(QUARTER_CAR_ID, **(env_kwargs or {}))
    try:
        task = env.unwrapped.task
        if steps > task.road_steps:
            raise ValueError(f"steps={steps} exceeds one generated road stretch ({task.road_steps})")
        rows = []
        for s in seeds:
            env.reset(seed=int(s))
            rows.append(task.s["road"][0, : steps + 1].copy())
        return np.stack(rows), float(task.control_dt), task.base_rows[0]
    finally:
        env.close()


def ideal_skyhook_reference(seeds: Sequence[int], steps: int, c_sky: float = SkyhookConfig.c_sky,
                            params: ElpasParams | None = None,
                            env_kwargs: dict[str, Any] | None = None) -> dict[str, Any]:
    """Comfort of the ideal-force skyhook (upper reference, ignores actuator limits) on the env's roads.

    Returns ``comfort_aw_rms`` (mean over seeds, ISO 2631-1 W_k, causal filter from t = 0 as in
    the env), ``travel_rms_m``, ``tyre_load_rms``, and the same for the linear passive car
    (``c_sky = 0``) as a check of the linearisation against the environment's passive baseline.
    """
    roads, dt, env_params = env_roads(seeds, steps, env_kwargs)
    p = env_params if params is None else params
    t = dt * np.arange(roads.shape[1])
    F0 = (float(p.car.m_s) + float(p.car.m_u)) * GRAVITY
    out: dict[str, Any] = {"label": "ideal-force skyhook (upper reference; no actuator, no limits)"}
    for name, c in (("skyhook", c_sky), ("passive_linear", 0.0)):
        sysm = linear_quarter_car(p, c)
        aw, tr, ty = [], [], []
        for road in roads:
            _, y, _ = signal.lsim(sysm, road, t)
            aw.append(weighted_rms(y[1:, 0], 1.0 / dt))
            tr.append(float(np.sqrt(np.mean(y[1:, 1] ** 2))))
            ty.append(float(np.sqrt(np.mean((y[1:, 2] / F0) ** 2))))
        out[name] = {"comfort_aw_rms": float(np.mean(aw)), "travel_rms_m": float(np.mean(tr)),
                     "tyre_load_rms": float(np.mean(ty))}
    out.update(out["skyhook"])
    return out
