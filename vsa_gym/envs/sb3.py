"""Adapter from the native vector environments to stable-baselines3's ``VecEnv``.

SB3 does not accept Gymnasium vector environments; :class:`SB3VecEnv` presents a
:class:`~vsa_gym.envs.vector.TaskVectorEnv` (built with ``SAME_STEP`` autoreset) with
SB3's conventions: ``step_wait`` resets finished sub-environments itself, puts
the last observation in ``infos[i]["terminal_observation"]`` and sets
``infos[i]["TimeLimit.truncated"]`` for time-limit ends::

    from stable_baselines3 import PPO
    from vsa_gym.envs.sb3 import make_sb3_vec_env
    venv = make_sb3_vec_env("vsa_gym/ELPAS-ForceTracking-v0", n_envs=16, seed=0)
    PPO("MlpPolicy", venv).learn(100_000)

Importing this module requires stable-baselines3 (the ``rl`` extra).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode
from stable_baselines3.common.vec_env.base_vec_env import VecEnv, VecEnvIndices, VecEnvObs, VecEnvStepReturn

from vsa_gym.envs.vector import TaskVectorEnv


class SB3VecEnv(VecEnv):
    """stable-baselines3 ``VecEnv`` over a :class:`TaskVectorEnv` (see the module docstring)."""

    def __init__(self, venv: TaskVectorEnv) -> None:
        if not isinstance(venv, TaskVectorEnv):
            raise TypeError(f"SB3VecEnv wraps a vsa_gym TaskVectorEnv, got {type(venv).__name__}")
        if venv.autoreset_mode != AutoresetMode.SAME_STEP:
            raise ValueError("SB3VecEnv needs a vector env built with autoreset_mode=AutoresetMode.SAME_STEP")
        self.venv = venv
        super().__init__(venv.num_envs, venv.single_observation_space, venv.single_action_space)
        self.render_mode = venv.render_mode
        self._actions: np.ndarray | None = None
        self._seeds: list[int | None] = [None] * venv.num_envs

    def reset(self) -> VecEnvObs:
        seeds = self._seeds if any(s is not None for s in self._seeds) else None
        obs, _ = self.venv.reset(seed=seeds)  # type: ignore[arg-type]
        self._seeds = [None] * self.num_envs
        self.reset_infos = [{} for _ in range(self.num_envs)]
        return obs

    def seed(self, seed: int | None = None) -> Sequence[None | int]:
        if seed is None:
            seed = int(np.random.SeedSequence().generate_state(1)[0])
        self._seeds = [seed + i for i in range(self.num_envs)]
        return self._seeds

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = np.asarray(actions)

    def step_wait(self) -> VecEnvStepReturn:
        assert self._actions is not None, "step_async must be called first"
        obs, reward, terminated, truncated, info = self.venv.step(self._actions)
        self._actions = None
        infos: list[dict[str, Any]] = []
        for i in range(self.num_envs):
            d: dict[str, Any] = {k: v[i] for k, v in info.items()
                                 if not k.startswith("_") and k not in ("final_obs", "final_info")}
            if terminated[i] or truncated[i]:
                d["terminal_observation"] = info["final_obs"][i]
                d["TimeLimit.truncated"] = bool(truncated[i] and not terminated[i])
                d.update(info["final_info"][i])
            infos.append(d)
        return obs, reward.astype(np.float32), terminated | truncated, infos

    def close(self) -> None:
        self.venv.close()

    def get_images(self) -> Sequence[np.ndarray | None]:
        frames = self.venv.render()
        return list(frames) if frames is not None else [None] * self.num_envs

    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        return [getattr(self.venv, attr_name) for _ in self._get_indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        setattr(self.venv, attr_name, value)

    def env_method(self, method_name: str, *method_args: Any, indices: VecEnvIndices = None,
                   **method_kwargs: Any) -> list[Any]:
        fn = getattr(self.venv, method_name)
        return [fn(*method_args, **method_kwargs) for _ in self._get_indices(indices)]

    def env_is_wrapped(self, wrapper_class: type[gym.Wrapper], indices: VecEnvIndices = None) -> list[bool]:
        return [False for _ in self._get_indices(indices)]


def make_sb3_vec_env(env_id: str, n_envs: int = 8, seed: int | None = None, **kwargs: Any) -> SB3VecEnv:
    """An SB3 ``VecEnv`` of ``n_envs`` rows of a registered vsa_gym environment (native batched physics)."""
    venv = gym.make_vec(env_id, num_envs=n_envs, vectorization_mode="vector_entry_point",
                        vector_kwargs={}, autoreset_mode=AutoresetMode.SAME_STEP, **kwargs)
    inner = venv.unwrapped if hasattr(venv, "unwrapped") else venv
    if not isinstance(inner, TaskVectorEnv):
        raise TypeError(f"{env_id} did not give a native vsa_gym vector env")
    out = SB3VecEnv(inner)
    if seed is not None:
        out.seed(seed)
    return out
