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

A second form, :class:`SetpointResidualVecEnv`, corrects the baseline's *references* instead of its
action: action component ``j`` shifts the observation channels ``channels[j]`` by ``scales[j] * a_j``
before the baseline reads them, and the environment receives the baseline's action on the shifted
observation; the agent observes the environment's observation.  On the vsaUT-II the agent then moves the
decoupled controller's position and stiffness references (``r_ref``, ``log_K_ref``): the controller's I^2 t
foldback, supply limits and anti-windup stay between the agent and the motors, so exploration cannot
drive raw voltages into the drives' protection as an action correction does.

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

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from stable_baselines3.common.vec_env import VecEnv, VecEnvWrapper
from stable_baselines3.common.vec_env.base_vec_env import VecEnvStepReturn

from agents.common import wrapper_kwargs

RESIDUAL_CLASS = "agents.residual.ResidualVecEnv"
SETPOINT_CLASS = "agents.residual.SetpointResidualVecEnv"
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
    """The ``ResidualVecEnv`` or ``SetpointResidualVecEnv`` kwargs in a ``vec_env_wrapper`` hyperparameter entry
    (``None``: not residual); a setpoint entry has ``"form": "setpoint"``."""
    kw = wrapper_kwargs(vec_env_wrapper, RESIDUAL_CLASS)
    if kw is not None:
        return kw
    kw = wrapper_kwargs(vec_env_wrapper, SETPOINT_CLASS)
    return None if kw is None else {**kw, "form": "setpoint"}


def task_env(venv: VecEnv) -> Any:
    """An object with ``.unwrapped.task`` for the baselines' factories (native vector env or rl-zoo3's DummyVecEnv)."""
    env = venv.get_attr("unwrapped", [0])[0]
    if not hasattr(env, "task"):
        raise TypeError("ResidualVecEnv needs a vsa_gym environment (its .unwrapped.task)")
    return env


def check_mode(name: str, task: Any) -> None:
    """Raise where baseline ``name`` outputs current references and ``task`` is not in current mode."""
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


def restart_rows(policy: Any, factory: Callable[[Any], Any], env: Any, obs_rows: np.ndarray, rows: np.ndarray,
                 n: int) -> np.ndarray:
    """Rows ``rows`` of ``policy`` (a baseline on ``n`` rows) start new episodes: a fresh baseline from ``factory``
    takes its first call on their observations ``obs_rows`` and its states replace theirs (:func:`reset_rows`).
    Returns the fresh baseline's actions for those rows, ``(len(rows), m)`` float32."""
    fresh = factory(env)
    if hasattr(fresh, "reset"):
        fresh.reset()
    act = np.asarray(fresh(obs_rows), dtype=np.float32).reshape(len(rows), -1)
    reset_rows(policy, fresh, rows, n)
    return act


class ResidualVecEnv(VecEnvWrapper):
    """Baseline action + ``scale`` x agent action; observation + baseline action (module docstring)."""

    def __init__(self, venv: VecEnv, baseline: str = "cascade", scale: float = 0.3) -> None:
        if not 0.0 < float(scale) <= 2.0:
            raise ValueError(f"scale must lie in (0, 2], got {scale}")
        self.baseline, self.scale = baseline, float(scale)
        self._env = task_env(venv)
        check_mode(baseline, self._env.unwrapped.task)
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
            base[rows] = restart_rows(self.policy, self._factory, self._env, obs[rows], rows, self.num_envs)
        self._base = base
        return self._aug(obs, base), rew, done, infos


class Setpoints:
    """The reference shift of :class:`SetpointResidualVecEnv`: ``shift(obs (n, d), a (n, m)) -> obs'``.

    ``channels[j]``: the observation names moved by action component ``j``; ``scales[j]``: how far (channel
    units) a full action moves them.
    """

    def __init__(self, names: Sequence[str], channels: Sequence[Sequence[str]], scales: Sequence[float]) -> None:
        if len(channels) != len(scales) or not channels:
            raise ValueError(f"channels and scales need one entry per action component, got {len(channels)} "
                             f"channel groups and {len(scales)} scales")
        names = list(names)
        self.cols: list[np.ndarray] = []
        for j, group in enumerate(channels):
            missing = [c for c in group if c not in names]
            if missing or not group:
                raise ValueError(f"setpoint component {j}: unknown observation channel(s) {missing or group}; "
                                 f"the environment has {names}")
            self.cols.append(np.array([names.index(c) for c in group], dtype=np.intp))
        self.scales = np.array([float(x) for x in scales])
        if not np.all(np.isfinite(self.scales) & (self.scales > 0)):
            raise ValueError(f"scales must be finite and > 0, got {list(scales)}")

    def shift(self, obs: np.ndarray, a: np.ndarray) -> np.ndarray:
        o = np.array(obs, dtype=np.float32, copy=True)
        a = np.clip(np.asarray(a, dtype=np.float32).reshape(o.shape[0], -1), -1.0, 1.0)
        if a.shape[1] != len(self.cols):
            raise ValueError(f"setpoint action has {a.shape[1]} components, expected {len(self.cols)}")
        for j, cols in enumerate(self.cols):
            o[:, cols] += (self.scales[j] * a[:, j])[:, None]
        return o


class SetpointResidualVecEnv(VecEnvWrapper):
    """The baseline on references shifted by the agent (module docstring).

    ``channels``: one list of observation names per action component (e.g. ``[[r_ref], [log_K_ref]]``);
    ``scales``: the shift of a full action per component, in the channels' units.  Action space
    ``Box(-1, 1, (len(channels),))``; observation: the environment's.
    """

    def __init__(self, venv: VecEnv, baseline: str = "decoupled", channels: Sequence[Sequence[str]] = (),
                 scales: Sequence[float] = ()) -> None:
        self.baseline = baseline
        self._env = task_env(venv)
        task = self._env.unwrapped.task
        check_mode(baseline, task)
        self.setpoints = Setpoints([c.name for c in task.obs_channels], channels, scales)
        self._factory = baseline_factory(baseline)
        self.policy = self._factory(self._env)
        m = len(self.setpoints.cols)
        act = gym.spaces.Box(-np.ones(m, dtype=np.float32), np.ones(m, dtype=np.float32), dtype=np.float32)
        super().__init__(venv, observation_space=venv.observation_space, action_space=act)
        self._obs = np.zeros((self.num_envs, *venv.observation_space.shape), dtype=np.float32)
        self._fresh = np.arange(0)

    def reset(self) -> np.ndarray:
        self._obs = np.asarray(self.venv.reset(), dtype=np.float32)
        if hasattr(self.policy, "reset"):
            self.policy.reset()
        self._fresh = np.arange(0)
        return self._obs

    def step_async(self, actions: np.ndarray) -> None:
        shifted = self.setpoints.shift(self._obs, actions)
        u = np.asarray(self.policy(shifted), dtype=np.float32).reshape(self.num_envs, -1)
        rows = self._fresh
        if rows.size and rows.size < self.num_envs:  # rows of new episodes: a fresh baseline's first call
            u[rows] = restart_rows(self.policy, self._factory, self._env, shifted[rows], rows, self.num_envs)
        self._fresh = np.arange(0)
        self.venv.step_async(np.clip(u, -1.0, 1.0))

    def step_wait(self) -> VecEnvStepReturn:
        obs, rew, done, infos = self.venv.step_wait()
        rows = np.flatnonzero(done)
        if rows.size == self.num_envs:  # every episode ended (time limit): a fresh baseline
            if hasattr(self.policy, "reset"):
                self.policy.reset()
        else:
            self._fresh = rows
        self._obs = np.asarray(obs, dtype=np.float32)
        return self._obs, rew, done, infos


class SetpointPolicy:
    """Evaluation-time composition ``baseline(shift(obs, agent(obs)))`` of :class:`SetpointResidualVecEnv`."""

    def __init__(self, agent: Callable[[np.ndarray], np.ndarray], baseline: Any, setpoints: Setpoints) -> None:
        self.agent, self.baseline, self.setpoints = agent, baseline, setpoints

    def reset(self) -> None:
        for part in (self.baseline, self.agent):
            if hasattr(part, "reset"):
                part.reset()

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        o = np.atleast_2d(np.asarray(obs, dtype=np.float32))
        a = np.asarray(self.agent(o), dtype=np.float32).reshape(o.shape[0], -1)
        u = np.asarray(self.baseline(self.setpoints.shift(o, a)), dtype=np.float32).reshape(o.shape[0], -1)
        out = np.clip(u, -1.0, 1.0)
        return out[0] if np.ndim(obs) == 1 else out


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
    setpoint = config.get("form") == "setpoint"
    factory = baseline_factory(name)

    def make(env: Any) -> ResidualPolicy | SetpointPolicy:
        task = env.unwrapped.task
        check_mode(name, task)
        inner = agent if agent_factory is None else agent_factory(env)
        if setpoint:
            sp = Setpoints([c.name for c in task.obs_channels], config.get("channels", ()), config.get("scales", ()))
            return SetpointPolicy(inner, factory(env), sp)
        return ResidualPolicy(inner, factory(env), scale)

    return make
