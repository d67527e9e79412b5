"""Native Gymnasium vector environment over a batched task (one batched physics call per step).

``gym.make_vec("vsa_gym/<id>", num_envs=n)`` builds a :class:`TaskVectorEnv`
subclass through the registry's ``vector_entry_point``: the ``n`` sub-environments
are the rows of one :class:`~vsa_gym.envs.task.BatchedTask`, so the physics core
is called once per step for all of them.

Semantics are those of :class:`gymnasium.vector.SyncVectorEnv` over ``n`` copies of
the single environment wrapped in ``TimeLimit``:

* ``reset(seed=s)`` seeds sub-environment ``i`` with ``s + i`` (a list gives one
  seed each); ``options={"reset_mask": mask}`` resets only some rows;
* truncation at ``max_episode_steps`` (from the registry) per row;
* autoreset mode ``NEXT_STEP`` (default): the step after an episode end returns the
  reset observation, reward 0 and ``terminated = truncated = False``, ignoring that
  row's action; ``SAME_STEP``: the row is reset in the same step and the final
  observation and info are in ``info["final_obs"]`` / ``info["final_info"]``;
  ``DISABLED``: the caller resets with ``reset_mask``.
* ``info`` holds one array per key with a boolean mask ``info["_key"]``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, ClassVar

import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from vsa_gym.envs.task import BatchedTask, horizon_from_time_limit


class TaskVectorEnv(VectorEnv):
    """``num_envs`` rows of a batched task as a Gymnasium ``VectorEnv`` (module docstring)."""

    task_cls: ClassVar[type[BatchedTask]]
    metadata: ClassVar[dict[str, Any]] = {"render_modes": ["rgb_array"], "render_fps": 25,
                                          "autoreset_mode": AutoresetMode.NEXT_STEP}
    render_size: ClassVar[tuple[int, int]] = (480, 720)
    #: tasks whose failure charges the steps an episode skipped take the time limit as their ``episode_steps``
    #: (the horizon of that charge) unless ``episode_steps`` is given
    time_limit_is_horizon: ClassVar[bool] = False

    def __init__(self, num_envs: int = 1, *, max_episode_steps: int | None = None, render_mode: str | None = None,
                 autoreset_mode: str | AutoresetMode = AutoresetMode.NEXT_STEP, **task_kwargs: Any) -> None:
        if render_mode is not None and render_mode not in ("rgb_array",):
            raise ValueError(f"vector render_mode must be 'rgb_array' or None, got {render_mode!r}")
        if self.time_limit_is_horizon:
            horizon_from_time_limit(max_episode_steps, task_kwargs)
        self.task = self.task_cls(num_envs, **task_kwargs)
        self.task.record_history = render_mode is not None
        self.num_envs = self.task.n
        self.render_mode = render_mode
        self.autoreset_mode = AutoresetMode(autoreset_mode)
        self.metadata = {**type(self).metadata, "autoreset_mode": self.autoreset_mode}
        if max_episode_steps is not None and max_episode_steps < 1:
            raise ValueError(f"max_episode_steps must be >= 1 or None, got {max_episode_steps}")
        self.max_episode_steps = max_episode_steps
        self.single_observation_space = self.task.single_observation_space()
        self.single_action_space = self.task.single_action_space()
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self._elapsed = np.zeros(self.num_envs, dtype=np.int64)
        self._autoreset = np.zeros(self.num_envs, dtype=bool)
        self._has_reset = False
        self._renderer: Any = None

    # ------------------------------------------------------------------ API
    def reset(self, *, seed: int | Sequence[int | None] | None = None,
              options: dict[str, Any] | None = None) -> tuple[np.ndarray, dict[str, Any]]:
        n = self.num_envs
        if seed is None:
            seeds: list[int | None] = [None] * n
        elif isinstance(seed, int | np.integer):
            seeds = [int(seed) + i for i in range(n)]
        else:
            seeds = list(seed)
            if len(seeds) != n:
                raise ValueError(f"seed list must have num_envs={n} entries, got {len(seeds)}")
        mask = np.ones(n, dtype=bool)
        if options is not None and "reset_mask" in options:
            mask = np.asarray(options["reset_mask"])
            if mask.shape != (n,) or mask.dtype != np.bool_ or not mask.any():
                raise ValueError(f"options['reset_mask'] must be a bool array of shape ({n},) with a True entry")
        elif not self._has_reset and seed is None:
            # first reset without a seed: fresh entropy per row (as the single env does)
            seeds = [int(np.random.SeedSequence().generate_state(1)[0]) for _ in range(n)]
        rows = np.flatnonzero(mask)
        self.task.seed_rows(rows, [seeds[i] for i in rows])
        self.task.reset(rows)
        self._elapsed[rows] = 0
        self._autoreset[rows] = False
        self._has_reset = True
        return self.task.observation(), self._vector_info(self.task.reset_info(rows), rows)

    def step(self, actions: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        if not self._has_reset:
            raise RuntimeError("call reset() before step()")
        task = self.task
        a, _ = task.validate_action(actions)  # raises before anything changes
        if self.autoreset_mode == AutoresetMode.DISABLED and np.any(self._autoreset):
            raise RuntimeError("autoreset is disabled: reset the finished sub-environments with reset_mask first")
        done_rows = np.flatnonzero(self._autoreset) if self.autoreset_mode == AutoresetMode.NEXT_STEP else \
            np.zeros(0, dtype=np.intp)
        snap = None
        if done_rows.size:
            task.reset(done_rows)
            self._elapsed[done_rows] = 0
            reset_info = task.reset_info(done_rows)
            snap = task.snapshot(done_rows)
        obs, reward, terminated, info = task.step(np.asarray(actions, dtype=np.float64))
        del a
        self._elapsed += 1
        truncated = np.zeros(self.num_envs, dtype=bool)
        if self.max_episode_steps is not None:
            truncated = self._elapsed >= self.max_episode_steps
        if snap is not None:
            task.restore(done_rows, snap)
            obs[done_rows] = task.s["obs"][done_rows]
            reward[done_rows] = 0.0
            terminated[done_rows] = False
            truncated[done_rows] = False
            self._elapsed[done_rows] = 0
            for k, v in info.items():
                v[done_rows] = reset_info.get(k, 0)
        out_info = self._vector_info(info, np.arange(self.num_envs))
        ended = terminated | truncated
        if self.autoreset_mode == AutoresetMode.SAME_STEP and np.any(ended):
            rows = np.flatnonzero(ended)
            final_obs = np.full(self.num_envs, None, dtype=object)
            final_info = np.full(self.num_envs, None, dtype=object)
            for i in rows:
                final_obs[i] = obs[i].copy()
                final_info[i] = {k: v[i] for k, v in info.items()}
            task.reset(rows)
            self._elapsed[rows] = 0
            obs[rows] = task.s["obs"][rows]
            out_info["final_obs"], out_info["_final_obs"] = final_obs, ended.copy()
            out_info["final_info"], out_info["_final_info"] = final_info, ended.copy()
        self._autoreset = ended
        return obs, reward, terminated, truncated, out_info

    def render(self) -> tuple[np.ndarray, ...] | None:
        if self.render_mode is None:
            return None
        from vsa_gym.envs.rendering import Renderer

        if self._renderer is None:
            self._renderer = Renderer(self.render_size, title=type(self).__name__)
        return tuple(self._renderer.draw(self.task, i) for i in range(self.num_envs))

    def close_extras(self, **kwargs: Any) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

    # ------------------------------------------------------------------ helpers
    def _vector_info(self, info: dict[str, np.ndarray], rows: np.ndarray) -> dict[str, Any]:
        out: dict[str, Any] = {}
        mask = np.zeros(self.num_envs, dtype=bool)
        mask[rows] = True
        for k, v in info.items():
            v = np.asarray(v)
            if v.shape[0] == self.num_envs:
                full = v.copy()
            else:
                full = np.zeros((self.num_envs, *v.shape[1:]), dtype=v.dtype)
                full[rows] = v
            out[k] = full
            out[f"_{k}"] = mask.copy()
        return out
