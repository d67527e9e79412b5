"""Observation features: leaky integrals of observation channels, the memory an MLP policy lacks.

An MLP policy sees one observation at a time.  Some tasks need a quantity that only a time integral of the
sensors gives: the quarter car's skyhook damping needs the body's absolute speed, and the only body sensor
is an accelerometer (``body_accel``); the skyhook baseline integrates it with a leak
(:class:`baselines.quarter_car.SkyhookCascade`).  :class:`LeakyIntegralVecEnv` gives the agent the same
signal: for each named channel ``c`` it appends::

    z_k = lambda z_{k-1} + dt o_k[c],    lambda = exp(-2 pi f_leak dt),    z = 0 at an episode start

(a first-order high-pass of the integral, corner ``f_leak``; ``dt`` is the environment's ``control_dt``),
returned as ``g z`` with ``g = (1 - lambda) / dt`` (about ``2 pi f_leak``): a unit DC gain, so the feature
carries the channel's size (a constant input ``u`` settles at ``u``; the integral of ``body_accel`` is the
body speed times ``g``).  With ``lp_hz`` the feature is also low-passed,
``y_k = y_{k-1} + beta (g z_k - y_{k-1})``, ``beta = 1 - exp(-2 pi f_lp dt)``, ``y = 0`` at an episode start:
the skyhook baseline's own speed estimate (its ``hp_hz`` 0.3 Hz and ``lp_hz`` 1.5 Hz), aimed at the body mode
rather than the wheel hop.  The feature is a fixed filter of the agent's own observations, like frame stacking:
it adds no controller and no information the sensors do not hold, so an agent with it is still a pure
learned policy.  It is an SB3 ``VecEnvWrapper`` (rl-zoo3's ``vec_env_wrapper``, applied before
``VecNormalize``), usable after :class:`agents.residual.ResidualVecEnv` in the same list;
:func:`feature_policy` rebuilds the same filter for :mod:`agents.evaluate`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from stable_baselines3.common.vec_env import VecEnv, VecEnvWrapper
from stable_baselines3.common.vec_env.base_vec_env import VecEnvStepReturn

from agents.common import wrapper_kwargs

FEATURE_CLASS = "agents.features.LeakyIntegralVecEnv"


def _task(env: Any) -> Any:
    task = getattr(getattr(env, "unwrapped", env), "task", None)
    if task is None:
        raise TypeError("leaky-integral features need a vsa_gym environment (its .unwrapped.task)")
    return task


class LeakyIntegral:
    """The filter of the module docstring on ``n`` rows: ``update(obs (n, d)) -> features (n, k)``.

    ``channels``: observation names of the task (``task.obs_channels``); ``dt`` (s); ``leak_hz`` (Hz, > 0);
    ``lp_hz`` (Hz, > 0, or ``None``: no low-pass).
    """

    def __init__(self, names: Sequence[str], channels: Sequence[str], dt: float, leak_hz: float,
                 lp_hz: float | None = None) -> None:
        if not channels:
            raise ValueError("channels must name at least one observation channel")
        missing = [c for c in channels if c not in names]
        if missing:
            raise ValueError(f"unknown observation channel(s) {missing}; the environment has {list(names)}")
        if not (np.isfinite(leak_hz) and leak_hz > 0):
            raise ValueError(f"leak_hz must be a finite corner frequency > 0 Hz, got {leak_hz!r}")
        if lp_hz is not None and not (np.isfinite(lp_hz) and lp_hz > 0):
            raise ValueError(f"lp_hz must be a finite corner frequency > 0 Hz (or None: no low-pass), got {lp_hz!r}")
        if not (np.isfinite(dt) and dt > 0):
            raise ValueError(f"dt must be > 0 s, got {dt!r}")
        self.idx = np.array([list(names).index(c) for c in channels], dtype=np.intp)
        self.dt, self.leak_hz = float(dt), float(leak_hz)
        self.leak = float(np.exp(-2.0 * np.pi * self.leak_hz * self.dt))
        self.gain = (1.0 - self.leak) / self.dt  # unit DC gain (about 2 pi leak_hz)
        self.lp_hz = None if lp_hz is None else float(lp_hz)
        self.beta = None if lp_hz is None else 1.0 - float(np.exp(-2.0 * np.pi * self.lp_hz * self.dt))
        self.z = np.zeros((0, self.idx.size))
        self.y = np.zeros((0, self.idx.size))

    def reset(self, n: int | None = None, rows: np.ndarray | None = None) -> None:
        """Zero every row (``n`` rows) or only ``rows``."""
        if rows is None:
            self.z = np.zeros((self.z.shape[0] if n is None else int(n), self.idx.size))
            self.y = np.zeros_like(self.z)
        else:
            self.z[rows] = 0.0
            self.y[rows] = 0.0

    def _next(self, z: np.ndarray, y: np.ndarray, o: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        z = self.leak * z + self.dt * o[:, self.idx]
        return z, (self.gain * z if self.beta is None else y + self.beta * (self.gain * z - y))

    def update(self, obs: np.ndarray) -> np.ndarray:
        o = np.atleast_2d(np.asarray(obs, dtype=np.float64))
        if self.z.shape[0] != o.shape[0]:
            self.reset(o.shape[0])
        self.z, self.y = self._next(self.z, self.y, o)
        return self.y.astype(np.float32)

    def peek(self, obs: np.ndarray, rows: np.ndarray) -> np.ndarray:
        """The features ``rows`` would have after ``obs`` (their observation), without updating the state."""
        o = np.atleast_2d(np.asarray(obs, dtype=np.float64))
        return self._next(self.z[rows], self.y[rows], o)[1].astype(np.float32)

    def bounds(self, low: np.ndarray, high: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Bounds of the features: the channels' own (a unit-DC-gain first-order filter of a bounded input stays
        within its bounds, and so does a unit-DC-gain low-pass of it)."""
        lo = np.asarray(low, dtype=np.float64)[self.idx]
        hi = np.asarray(high, dtype=np.float64)[self.idx]
        return lo.astype(np.float32), hi.astype(np.float32)


class LeakyIntegralVecEnv(VecEnvWrapper):
    """Observation + leaky integrals of ``channels`` (module docstring).  ``leak_hz``: corner (Hz); ``lp_hz``:
    the optional low-pass corner (Hz)."""

    def __init__(self, venv: VecEnv, channels: Sequence[str] = ("body_accel",), leak_hz: float = 0.3,
                 lp_hz: float | None = None) -> None:
        env = venv.get_attr("unwrapped", [0])[0]
        task = _task(env)
        names = [c.name for c in task.obs_channels]
        self.filter = LeakyIntegral(names, list(channels), float(task.control_dt), float(leak_hz), lp_hz)
        self.channels, self.leak_hz = tuple(channels), float(leak_hz)
        obs = venv.observation_space
        lo, hi = self.filter.bounds(obs.low, obs.high)
        space = gym.spaces.Box(np.concatenate([obs.low, lo]).astype(np.float32),
                               np.concatenate([obs.high, hi]).astype(np.float32), dtype=np.float32)
        super().__init__(venv, observation_space=space)

    def reset(self) -> np.ndarray:
        obs = self.venv.reset()
        self.filter.reset(obs.shape[0])
        return np.concatenate([obs, self.filter.update(obs)], axis=1)

    def step_wait(self) -> VecEnvStepReturn:
        obs, rew, done, infos = self.venv.step_wait()
        rows = np.flatnonzero(done)
        for i in rows:  # the ended episode's last observation carries that episode's integral
            term = np.asarray(infos[i]["terminal_observation"], dtype=np.float32)
            infos[i]["terminal_observation"] = np.concatenate([term, self.filter.peek(term, np.array([i]))[0]])
        if rows.size:
            self.filter.reset(rows=rows)
        return np.concatenate([obs, self.filter.update(obs)], axis=1), rew, done, infos


class FeaturePolicy:
    """Evaluation-time composition ``agent([obs, features(obs)])`` with the filter restarted by ``reset()``."""

    def __init__(self, agent: Callable[[np.ndarray], np.ndarray], filt: LeakyIntegral) -> None:
        self.agent, self.filter = agent, filt

    def reset(self) -> None:
        self.filter.reset(0)
        if hasattr(self.agent, "reset"):
            self.agent.reset()

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        o = np.atleast_2d(np.asarray(obs, dtype=np.float32))
        a = np.asarray(self.agent(np.concatenate([o, self.filter.update(o)], axis=1)), dtype=np.float32)
        return a.reshape(o.shape[0], -1)[0] if np.ndim(obs) == 1 else a.reshape(o.shape[0], -1)


def feature_config(vec_env_wrapper: Any) -> dict[str, Any] | None:
    """The ``LeakyIntegralVecEnv`` kwargs in a ``vec_env_wrapper`` entry (``None``: no feature wrapper)."""
    return wrapper_kwargs(vec_env_wrapper, FEATURE_CLASS)


def feature_policy(agent_factory: Callable[[Any], Any], config: Mapping[str, Any]) -> Callable[[Any], Any]:
    """``policy_factory(env)``: the agent built by ``agent_factory(env)`` behind the filter of ``config``."""
    channels = list(config.get("channels", ("body_accel",)))
    leak_hz = float(config.get("leak_hz", 0.3))
    lp_hz = config.get("lp_hz")

    def make(env: Any) -> FeaturePolicy:
        task = _task(env)
        filt = LeakyIntegral([c.name for c in task.obs_channels], channels, float(task.control_dt), leak_hz, lp_hz)
        return FeaturePolicy(agent_factory(env), filt)

    return make
