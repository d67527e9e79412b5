"""Action hold: the agent decides every ``steps`` control steps and its action is held in between.

A zero-order hold on the agent's actions, like the Throw baselines' schedules (piecewise constant over
segments of 10 control steps, :mod:`baselines.vsaut2_throw`).  The environment keeps its own control step
(2 ms on the vsaUT-II), so everything it scores -- the release detected within one 2 ms step, energy, limits --
is unchanged; only the agent's decision rate drops (to 50 Hz with ``steps: 10``), which shortens the credit
assignment of a throw from ~200 decisions to ~20.  Running the task itself at a 20 ms control step instead is
not the same task: the release speed is the output speed at the end of the control step in which the release
angle is crossed, so it would be read up to 20 ms after the crossing, while the output still accelerates.

:class:`ActionHoldVecEnv` is an SB3 ``VecEnvWrapper`` (rl-zoo3's ``vec_env_wrapper``, before ``VecNormalize``):
one agent step is ``steps`` steps of the wrapped vector env with the same action; the rewards are summed.  A row
whose episode ends inside a hold returns that episode's end (summed reward, ``done``, its ``info`` with the
terminal observation); for the rest of the hold it idles in its new episode at the zero action, and its next
observation is the one after those idle steps (their rewards belong to no decision and are dropped).  Once every
row has ended, the hold stops there (no row idles).
:func:`hold_policy` rebuilds the same hold for :mod:`agents.evaluate`, where all rows start together.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import numpy as np
from stable_baselines3.common.vec_env import VecEnv, VecEnvWrapper
from stable_baselines3.common.vec_env.base_vec_env import VecEnvStepReturn

from agents.common import wrapper_kwargs

HOLD_CLASS = "agents.hold.ActionHoldVecEnv"
DEFAULT_STEPS = 10  # control steps per decision where an entry names the wrapper without ``steps``


def _steps(value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or int(value) < 1:
        raise ValueError(f"steps must be an integer >= 1 (control steps per agent decision), got {value!r}")
    return int(value)


class ActionHoldVecEnv(VecEnvWrapper):
    """Each agent action held for ``steps`` control steps of ``venv`` (module docstring)."""

    def __init__(self, venv: VecEnv, steps: int = DEFAULT_STEPS) -> None:
        self.steps = _steps(steps)
        super().__init__(venv)
        self._actions: np.ndarray | None = None

    def reset(self) -> np.ndarray:
        return self.venv.reset()

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = np.array(actions, dtype=np.float32, copy=True)

    def step_wait(self) -> VecEnvStepReturn:
        if self._actions is None:
            raise RuntimeError("step_wait() without step_async()")
        a, self._actions = self._actions, None
        n = self.num_envs
        total = np.zeros(n, dtype=np.float32)
        ended = np.zeros(n, dtype=bool)
        infos: list[dict[str, Any]] = [{} for _ in range(n)]
        obs: np.ndarray | None = None
        for _ in range(self.steps):
            o, r, d, inf = self.venv.step(a)
            live = ~ended
            total[live] += r[live]
            for i in np.flatnonzero(live):
                infos[i] = inf[i]
            obs = o  # every row's latest observation (an ended row's: its new episode after the idle steps)
            new = live & np.asarray(d, dtype=bool)
            ended |= new
            a[new] = 0.0
            if ended.all():
                break
        assert obs is not None
        return obs, total, ended, infos


class HoldPolicy:
    """Evaluation-time hold: ``agent`` asked every ``steps`` calls, its action repeated in between."""

    def __init__(self, agent: Callable[[np.ndarray], np.ndarray], steps: int) -> None:
        self.agent, self.steps = agent, _steps(steps)
        self.k = 0
        self.action: np.ndarray | None = None

    def reset(self) -> None:
        self.k, self.action = 0, None
        if hasattr(self.agent, "reset"):
            self.agent.reset()

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        if self.action is None or self.k % self.steps == 0:
            self.action = np.asarray(self.agent(obs), dtype=np.float32)
        self.k += 1
        return self.action


def hold_policy(agent_factory: Callable[[Any], Any], config: Mapping[str, Any]) -> Callable[[Any], Any]:
    """``policy_factory(env)``: the agent built by ``agent_factory(env)`` behind the hold of ``config``."""
    steps = _steps(config.get("steps", DEFAULT_STEPS))
    return lambda env: HoldPolicy(agent_factory(env), steps)


def hold_config(vec_env_wrapper: Any) -> dict[str, Any] | None:
    """The ``ActionHoldVecEnv`` kwargs in a ``vec_env_wrapper`` entry (``None``: no hold)."""
    return wrapper_kwargs(vec_env_wrapper, HOLD_CLASS)


def hold_steps(vec_env_wrapper: Any) -> int | None:
    """Control steps per agent decision of a ``vec_env_wrapper`` entry (``None``: no hold, one per step)."""
    cfg = hold_config(vec_env_wrapper)
    return None if cfg is None else _steps(cfg.get("steps", DEFAULT_STEPS))


__all__ = ["DEFAULT_STEPS", "HOLD_CLASS", "ActionHoldVecEnv", "HoldPolicy", "hold_config", "hold_policy", "hold_steps"]
