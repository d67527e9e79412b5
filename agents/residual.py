"""Residual RL: the agent adds a learned, bounded correction to a baseline controller's action.

::

    python -m agents.train --env vsa_gym/ELPAS-ForceTracking-v0 --algo ppo --timesteps 500000 \\
        --hyperparams agents/hyperparams/ppo_residual.yml          # or: --residual cascade

The environment the agent sees (:class:`ResidualVecEnv`, an SB3 ``VecEnvWrapper`` applied to the
raw vector env, *before* ``VecNormalize``):

* action ``a`` in ``[-1, 1]^m``; the environment receives ``clip(a_base + scale * a, -1, 1)`` where
  ``a_base`` is the baseline controller's action for the current observation (the baseline runs
  on the raw observation, keeps its own filter / integrator states per row, and its rows are
  reset whenever an episode ends);
* observation: the environment's observation with ``a_base`` appended (the baseline's states
  are not observable otherwise, and the agent needs to know what it corrects).

The agent is therefore *not* a pure learned policy: tables label it "residual PPO over <baseline>".
With a zero correction it is the baseline; PPO's initial policy has a near-zero mean, so training
starts from the baseline's behaviour.  The same wrapper is in the rl-zoo3 format
(``vec_env_wrapper`` in ``agents/hyperparams/ppo_residual.yml``), applied there before
``VecNormalize`` as here.  Evaluation (:func:`residual_policy`) rebuilds the same composition on
the evaluation environment.

Baselines (the eLPAS ones act on current references: they need ``control_mode="current"``):
``cascade`` (force tracking), ``skyhook`` and ``passive`` (quarter car), ``decoupled`` (vsaUT-II).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import gymnasium as gym
import numpy as np
from stable_baselines3.common.vec_env import VecEnv, VecEnvWrapper
from stable_baselines3.common.vec_env.base_vec_env import VecEnvStepReturn

RESIDUAL_CLASS = "agents.residual.ResidualVecEnv"
CURRENT_MODE_BASELINES = frozenset({"cascade", "skyhook", "passive"})


def baseline_factory(name: str) -> Callable[[Any], Any]:
    """``policy_factory(env)`` of the baseline ``name`` (see the module docstring)."""
    if name == "cascade":
        from baselines.elpas_cascade import elpas_cascade_factory

        return elpas_cascade_factory()
    if name == "skyhook":
        from baselines.quarter_car import skyhook_factory

        return skyhook_factory()
    if name == "passive":
        from baselines.quarter_car import passive_factory

        return passive_factory()
    if name == "decoupled":
        from baselines.vsaut2_decoupled import vsaut2_decoupled_factory

        return vsaut2_decoupled_factory()
    raise ValueError(f"unknown residual baseline {name!r}; choose cascade, skyhook, passive or decoupled")


def residual_params(baseline: str, scale: float) -> dict[str, Any]:
    """Hyperparameter overrides that make a run residual over ``baseline`` (``--residual`` of agents.train)."""
    out: dict[str, Any] = {"vec_env_wrapper": [{RESIDUAL_CLASS: {"baseline": baseline, "scale": float(scale)}}]}
    if baseline in CURRENT_MODE_BASELINES:
        out["env_kwargs"] = {"control_mode": "current"}
    return out


def residual_config(vec_env_wrapper: Any) -> dict[str, Any] | None:
    """The ``ResidualVecEnv`` kwargs in a ``vec_env_wrapper`` hyperparameter entry (``None``: not residual)."""
    items = vec_env_wrapper if isinstance(vec_env_wrapper, list) else [vec_env_wrapper]
    for it in items:
        if isinstance(it, Mapping) and RESIDUAL_CLASS in it:
            return dict(it[RESIDUAL_CLASS] or {})
        if it == RESIDUAL_CLASS:
            return {}
    return None


def _task_env(venv: VecEnv) -> Any:
    """An object with ``.unwrapped.task`` for the baselines' factories (native vector env or rl-zoo3's DummyVecEnv)."""
    env = venv.get_attr("unwrapped", [0])[0]
    if not hasattr(env, "task"):
        raise TypeError("ResidualVecEnv needs a vsa_gym environment (its .unwrapped.task)")
    return env


def _check_mode(name: str, task: Any) -> None:
    if name in CURRENT_MODE_BASELINES and getattr(task, "control_mode", "current") != "current":
        raise ValueError(f"residual baseline {name!r} outputs current references: use env_kwargs "
                         "{control_mode: current}")


def reset_rows(policy: Any, fresh: Any, rows: np.ndarray, n: int) -> None:
    """Copy the per-row states of ``fresh`` (a new baseline run on ``len(rows)`` rows) into ``policy``'s rows.

    A baseline's state is every ndarray attribute whose first axis is the batch (filters, integrators).
    """
    k = len(rows)
    for name, v in vars(fresh).items():
        cur = getattr(policy, name, None)
        if isinstance(v, np.ndarray) and v.ndim >= 1 and v.shape[0] == k and isinstance(cur, np.ndarray) \
                and cur.ndim >= 1 and cur.shape[0] == n:
            cur[rows] = v


class ResidualVecEnv(VecEnvWrapper):
    """Baseline action + ``scale`` x agent action; observation + baseline action (module docstring)."""

    def __init__(self, venv: VecEnv, baseline: str = "cascade", scale: float = 0.3) -> None:
        if not 0.0 < float(scale) <= 2.0:
            raise ValueError(f"scale must lie in (0, 2], got {scale}")
        self.baseline, self.scale = baseline, float(scale)
        self._env = _task_env(venv)
        _check_mode(baseline, self._env.unwrapped.task)
        self._factory = baseline_factory(baseline)
        self.policy = self._factory(self._env)
        act = venv.action_space
        m = int(act.shape[0])
        obs = venv.observation_space
        space = gym.spaces.Box(np.concatenate([obs.low, -np.ones(m)]).astype(np.float32),
                               np.concatenate([obs.high, np.ones(m)]).astype(np.float32), dtype=np.float32)
        super().__init__(venv, observation_space=space, action_space=act)
        self._base = np.zeros((self.num_envs, m), dtype=np.float32)

    def _aug(self, obs: np.ndarray, base: np.ndarray) -> np.ndarray:
        return np.concatenate([obs, base], axis=-1).astype(np.float32)

    def _base_action(self, obs: np.ndarray) -> np.ndarray:
        return np.asarray(self.policy(obs), dtype=np.float32).reshape(obs.shape[0], -1)

    def reset(self) -> np.ndarray:
        obs = self.venv.reset()
        if hasattr(self.policy, "reset"):
            self.policy.reset()
        self._base = self._base_action(obs)
        return self._aug(obs, self._base)

    def step_async(self, actions: np.ndarray) -> None:
        a = np.clip(np.asarray(actions, dtype=np.float32), -1.0, 1.0).reshape(self._base.shape)
        self.venv.step_async(np.clip(self._base + self.scale * a, -1.0, 1.0))

    def step_wait(self) -> VecEnvStepReturn:
        obs, rew, done, infos = self.venv.step_wait()
        rows = np.flatnonzero(done)
        o = obs
        if rows.size:
            o = obs.copy()
            for i in rows:
                o[i] = infos[i]["terminal_observation"]
        base = self._base_action(o)  # continuing rows advance; ended rows see their last observation
        for i in rows:
            infos[i]["terminal_observation"] = self._aug(o[i], base[i])  # for the value bootstrap
        if rows.size == self.num_envs:  # every episode ended (time limit): a fresh baseline
            if hasattr(self.policy, "reset"):
                self.policy.reset()
            base = self._base_action(obs)
        elif rows.size:
            fresh = self._factory(self._env)
            if hasattr(fresh, "reset"):
                fresh.reset()
            base[rows] = np.asarray(fresh(obs[rows]), dtype=np.float32).reshape(rows.size, -1)
            reset_rows(self.policy, fresh, rows, self.num_envs)
        self._base = base
        return self._aug(obs, base), rew, done, infos


class ResidualPolicy:
    """Evaluation-time composition ``clip(baseline(obs) + scale * agent([obs, baseline(obs)]), -1, 1)``."""

    def __init__(self, agent: Callable[[np.ndarray], np.ndarray], baseline: Any, scale: float) -> None:
        self.agent, self.baseline, self.scale = agent, baseline, float(scale)

    def reset(self) -> None:
        if hasattr(self.baseline, "reset"):
            self.baseline.reset()
        if hasattr(self.agent, "reset"):  # an agent behind a stateful filter (agents.features)
            self.agent.reset()

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        o = np.atleast_2d(np.asarray(obs, dtype=np.float32))
        base = np.asarray(self.baseline(o), dtype=np.float32).reshape(o.shape[0], -1)
        a = np.asarray(self.agent(np.concatenate([o, base], axis=1)), dtype=np.float32).reshape(base.shape)
        out = np.clip(base + self.scale * np.clip(a, -1.0, 1.0), -1.0, 1.0)
        return out[0] if np.ndim(obs) == 1 else out


def residual_policy(agent: Callable[[np.ndarray], np.ndarray] | None, config: Mapping[str, Any],
                    agent_factory: Callable[[Any], Callable[[np.ndarray], np.ndarray]] | None = None
                    ) -> Callable[[Any], Any]:
    """``policy_factory(env)`` of a trained residual agent (``config``: the wrapper's kwargs of the run).

    ``agent``: the trained policy; or ``agent_factory(env)`` builds it per environment (an agent behind
    further wrappers, e.g. :func:`agents.features.feature_policy`).
    """
    if (agent is None) == (agent_factory is None):
        raise ValueError("give exactly one of agent and agent_factory")
    name = str(config.get("baseline", "cascade"))
    scale = float(config.get("scale", 0.3))
    factory = baseline_factory(name)

    def make(env: Any) -> ResidualPolicy:
        _check_mode(name, env.unwrapped.task)
        inner = agent if agent_factory is None else agent_factory(env)
        return ResidualPolicy(inner, factory(env), scale)

    return make
