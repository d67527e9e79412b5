"""The batched task: one implementation of an environment's logic for ``n`` sub-environments.

Every environment of :mod:`vsa_gym.envs` is a :class:`BatchedTask` subclass that
holds ``n`` copies of the device (one batched physics-core state), the
references, the sensor pipeline, the reward and the termination rules, all as
numpy arrays with a leading axis ``n``.  The single environment
(:class:`TaskEnv`, ``n = 1``) and the native vector environment
(:class:`vsa_gym.envs.vector.TaskVectorEnv`) both drive the same task object, so a
vector of ``n`` equals ``n`` single environments by construction.

Randomness: every row has its own ``numpy.random.Generator`` (``self.rngs[i]``),
created with :func:`gymnasium.utils.seeding.np_random` from the reset seed.  A
row never touches another row's generator, so row ``i`` of a vector reset with
seed ``s`` reproduces a single environment reset with seed ``s + i``.

Mutable per-row state lives in ``self.s`` (a dict of arrays with leading axis
``n``); everything else (parameters, models) changes only on reset.  This lets
the vector environment snapshot and restore rows (autoreset) generically.

Action policy (all environments): actions must have the declared shape and be
finite -- a NaN or infinite component raises ``ValueError`` naming the
component, *before* anything is changed, so the state is never corrupted.
Finite components outside ``[-1, 1]`` are clipped to the box; ``info["action_clipped"]``
reports it.
"""

from __future__ import annotations

import dataclasses
from abc import ABC, abstractmethod
from collections.abc import Mapping, Sequence
from typing import Any, ClassVar, Literal

import gymnasium as gym
import numba
import numpy as np
from gymnasium.utils import seeding
from numba.extending import register_jitable

from vsa_gym.envs.randomization import DomainRandomization
from vsa_gym.envs.sensing import NoiseSpec, resolve_noise

ControlMode = Literal["voltage", "current"]
RegenPolicy = Literal["clip", "count"]


@dataclasses.dataclass(frozen=True)
class ObsChannel:
    """One observation entry: name, unit, bounds and meaning (the docstring tables are built from these)."""

    name: str
    unit: str
    low: float
    high: float
    doc: str


def obs_table(channels: Sequence[ObsChannel]) -> str:
    """The observation table as markdown (index, name, unit, low, high, meaning)."""
    lines = ["| # | name | unit | low | high | meaning |", "|---|---|---|---|---|---|"]
    for k, c in enumerate(channels):
        lines.append(f"| {k} | `{c.name}` | {c.unit} | {c.low:.6g} | {c.high:.6g} | {c.doc} |")
    return "\n".join(lines)


def failure_horizon(env_name: str, failure_rate: float | None, episode_steps: int | None) -> tuple[float | None, int]:
    """Checked ``(failure_rate, episode_steps)`` of a task whose failure charges the steps it skips.

    A failure at step ``k`` costs ``failure_penalty + failure_rate (episode_steps - k)``: a fixed penalty
    alone lets a policy end episodes on purpose when the rest of the episode would cost more.
    ``episode_steps`` defaults to the registered time limit of ``env_name``; ``failure_rate`` may be
    ``None`` where the task computes its own default.
    """
    if failure_rate is not None and not (np.isfinite(failure_rate) and failure_rate >= 0):
        raise ValueError(f"failure_rate must be a finite rate >= 0 per remaining step, got {failure_rate}")
    if episode_steps is None:
        from vsa_gym.envs import ENV_SPECS

        episode_steps = ENV_SPECS[env_name][1]
    if int(episode_steps) != episode_steps or episode_steps < 1:
        raise ValueError(f"episode_steps must be a positive integer (the time limit in steps), got {episode_steps}")
    return (None if failure_rate is None else float(failure_rate)), int(episode_steps)


@register_jitable
def failure_charge(penalty: Any, rate: Any, steps_done: Any, episode_steps: Any) -> Any:
    """``-(penalty + rate max(episode_steps - steps_done, 0))``: the failure term of a failure after ``steps_done``
    control steps (see :func:`failure_horizon`); arrays or scalars, and callable from the compiled steps."""
    return -(penalty + rate * np.maximum(episode_steps - steps_done, 0.0))


def check_stop_barrier(w_stop: float, stop_width: float) -> tuple[float, float]:
    """Checked ``(w_stop, stop_width)`` of :func:`stop_barrier`: both finite, ``w_stop >= 0``, ``stop_width > 0``."""
    if not (np.isfinite(w_stop) and w_stop >= 0):
        raise ValueError(f"w_stop must be a finite weight >= 0, got {w_stop}")
    if not (np.isfinite(stop_width) and stop_width > 0):
        raise ValueError(f"stop_width must be a finite margin > 0 (the constraint's unit), got {stop_width}")
    return float(w_stop), float(stop_width)


@register_jitable
def stop_barrier(margin: float, w_stop: float, stop_width: float) -> float:
    """``-w_stop max(0, 1 - margin / stop_width)^2``: a cost that grows from 0, ``stop_width`` away from a
    constraint, to ``w_stop`` at contact (``margin`` = 0) and on past it, in the margin's unit.  A training aid:
    it prices the approach to a stop inside the learner's discount horizon, where the failure at the stop may lie
    beyond it; the tasks' default weight is 0."""
    d = 1.0 - margin / stop_width
    return -w_stop * d * d if d > 0.0 else 0.0


def horizon_from_time_limit(max_episode_steps: int | None, kwargs: dict[str, Any]) -> None:
    """A native vector env's time limit is also its task's ``episode_steps`` unless that is given (in place)."""
    if max_episode_steps is not None and kwargs.get("episode_steps") is None:
        kwargs["episode_steps"] = max_episode_steps


def indent(text: str, prefix: str = "    ") -> str:
    """Indent every line (for tables inserted into class docstrings)."""
    return "\n".join(prefix + line for line in text.splitlines())


class BatchedTask(ABC):
    """Base class of the batched environment logic (see the module docstring).

    Subclasses set the class attributes, build ``self.s`` in ``__init__`` (after
    calling ``super().__init__``), and implement :meth:`_reset_rows`, :meth:`step`
    (:class:`CompiledStepTask`: the task's compiled row functions) and :meth:`_observe`
    plus the drawing hooks.
    """

    action_names: ClassVar[tuple[str, ...]]
    reward_terms: ClassVar[tuple[str, ...]]
    default_control_dt: ClassVar[float]
    noise_defaults: ClassVar[Mapping[str, float]] = {}
    trace_names: ClassVar[tuple[str, ...]] = ()
    trace_units: ClassVar[tuple[str, ...]] = ()
    trace_groups: ClassVar[tuple[tuple[int, ...], ...]] = ()  # traces plotted together (indices)
    history_s: ClassVar[float] = 2.0  # seconds of traces kept for rendering

    def __init__(
        self,
        n: int,
        *,
        control_dt: float | None,
        control_mode: ControlMode,
        sensor_noise: NoiseSpec,
        domain_randomization: DomainRandomization | Mapping[str, tuple[float, float]] | None,
        regen: RegenPolicy,
    ) -> None:
        if not isinstance(n, int | np.integer) or n < 1:
            raise ValueError(f"number of environments must be an int >= 1, got {n!r}")
        self.n = int(n)
        dt = self.default_control_dt if control_dt is None else float(control_dt)
        if not np.isfinite(dt) or dt <= 0.0:
            raise ValueError(f"control_dt must be a positive time step in s, got {control_dt!r}")
        self.control_dt = dt
        if control_mode not in ("voltage", "current"):
            raise ValueError(f"control_mode must be 'voltage' or 'current', got {control_mode!r}")
        self.control_mode: ControlMode = control_mode
        if regen not in ("clip", "count"):
            raise ValueError(f"regen must be 'clip' or 'count', got {regen!r}")
        self.regen: RegenPolicy = regen
        self.noise = resolve_noise(sensor_noise, self.noise_defaults)
        if domain_randomization is None or isinstance(domain_randomization, DomainRandomization):
            self.randomization = domain_randomization
        else:
            self.randomization = DomainRandomization(domain_randomization)
        self.rngs: list[np.random.Generator] = [seeding.np_random(None)[0] for _ in range(self.n)]
        self.s: dict[str, np.ndarray] = {}
        self._hist_len = max(2, int(round(self.history_s / self.control_dt)))
        self._all_rows = np.arange(self.n)
        #: Keep the render history (:meth:`history`)?  The environments switch it off without a render_mode:
        #: nothing reads it then, and it cost a tenth of a single env's step.
        self.record_history = True

    # ------------------------------------------------------------------ spaces
    @property
    def obs_channels(self) -> tuple[ObsChannel, ...]:
        """The observation layout (depends on the parameters, hence per instance; set by :meth:`_set_channels`)."""
        return self._channels

    @property
    def obs_low(self) -> np.ndarray:
        return np.array([c.low for c in self.obs_channels], dtype=np.float32)

    @property
    def obs_high(self) -> np.ndarray:
        return np.array([c.high for c in self.obs_channels], dtype=np.float32)

    def single_observation_space(self) -> gym.spaces.Box:
        return gym.spaces.Box(self.obs_low, self.obs_high, dtype=np.float32)

    def single_action_space(self) -> gym.spaces.Box:
        m = len(self.action_names)
        return gym.spaces.Box(-np.ones(m, dtype=np.float32), np.ones(m, dtype=np.float32), dtype=np.float32)

    # ------------------------------------------------------------------ public API
    def seed_rows(self, rows: np.ndarray, seeds: Sequence[int | None]) -> None:
        """Give rows fresh generators from their seeds (``None`` keeps the current stream)."""
        for i, sd in zip(rows, seeds, strict=True):
            if sd is not None:
                self.rngs[int(i)] = seeding.np_random(int(sd))[0]

    def reset(self, rows: np.ndarray | None = None) -> None:
        """Start new episodes in ``rows`` (all by default), drawing from the rows' generators."""
        rows = np.arange(self.n) if rows is None else np.asarray(rows, dtype=np.intp)
        self._reset_rows(rows)
        self.s["t"][rows] = 0.0
        self.s["hist"][:, rows] = np.nan
        self.s["hist_pos"][rows] = 0
        self.s["obs"][rows] = self._clip_obs(self._observe(rows))
        self._record(rows)

    def validate_action(self, action: Any) -> tuple[np.ndarray, np.ndarray]:
        """Check shape and finiteness (``ValueError``), clip to ``[-1, 1]``; returns ``(a, clipped_rows)``."""
        m = len(self.action_names)
        try:
            a = np.asarray(action, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"action is not numeric: {action!r}") from exc
        if self.n == 1 and a.shape == (m,):
            a = a[None, :]
        if a.shape != (self.n, m):
            raise ValueError(f"action: expected shape ({m},) per environment, i.e. ({self.n}, {m}); got {a.shape}")
        a_clip, clipped, finite = _clip_actions(a)
        if not finite:
            bad = ~np.isfinite(a)
            row, k = (int(v) for v in np.argwhere(bad)[0])
            raise ValueError(
                f"action component {k} ({self.action_names[k]}) is {a[row, k]!r} in environment {row}; "
                "actions must be finite (nothing was changed)"
            )
        return a_clip, clipped

    def step(self, action: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict[str, np.ndarray]]:
        """Advance all rows one control step. Returns ``(obs, reward, terminated, info)`` batched."""
        raise NotImplementedError

    def step_single(self, action: Any) -> tuple[np.ndarray, float, bool, dict[str, Any]]:
        """:meth:`step` of row 0 as a single environment returns it: ``(obs, reward, terminated, info)`` with
        Python scalars in ``info`` (:class:`TaskEnv`)."""
        obs, reward, terminated, info = self.step(action)
        return obs[0], float(reward[0]), bool(terminated[0]), _row_info(info, 0)

    def observation(self) -> np.ndarray:
        return self.s["obs"].copy()

    def reset_info(self, rows: np.ndarray) -> dict[str, np.ndarray]:
        """Info returned by ``reset`` for ``rows``: time and the constraint margins."""
        info = {k: v for k, v in self._margins(rows).items()}
        info["time"] = self.s["t"][rows].copy()
        return info

    # ------------------------------------------------------------------ snapshots (vector autoreset)
    def snapshot(self, rows: np.ndarray) -> tuple[dict[str, np.ndarray], list[dict[str, Any]]]:
        state = {k: (v[:, rows].copy() if k == "hist" else v[rows].copy()) for k, v in self.s.items()}
        rng_states = [self.rngs[int(i)].bit_generator.state for i in rows]
        return state, rng_states

    def restore(self, rows: np.ndarray, snap: tuple[dict[str, np.ndarray], list[dict[str, Any]]]) -> None:
        state, rng_states = snap
        for k, v in state.items():
            if k == "hist":
                self.s[k][:, rows] = v
            else:
                self.s[k][rows] = v
        for i, st in zip(rows, rng_states, strict=True):
            self.rngs[int(i)].bit_generator.state = st

    # ------------------------------------------------------------------ helpers for subclasses
    def _set_channels(self, channels: list[ObsChannel]) -> None:
        """Fix the observation layout and allocate the per-task arrays (call at the end of ``__init__``)."""
        self._channels = tuple(channels)
        # float64 bounds for _clip_obs, derived once: the channels are fixed per instance
        self._obs_lo64 = self.obs_low.astype(np.float64)
        self._obs_hi64 = self.obs_high.astype(np.float64)
        self._alloc(len(self._channels))

    def _alloc(self, n_obs: int) -> None:
        """Allocate the bookkeeping arrays every task has (call at the end of ``__init__``)."""
        self.s["t"] = np.zeros(self.n)
        self.s["obs"] = np.zeros((self.n, n_obs), dtype=np.float32)
        self.s["hist"] = np.full((self._hist_len, self.n, max(1, len(self.trace_names))), np.nan)
        self.s["hist_pos"] = np.zeros(self.n, dtype=np.intp)

    def _clip_obs(self, obs: np.ndarray) -> np.ndarray:
        return np.minimum(np.maximum(obs, self._obs_lo64), self._obs_hi64).astype(np.float32)  # np.clip, cheaper

    def _record(self, rows: np.ndarray) -> None:
        if not self.trace_names or not self.record_history:
            return
        vals = self._traces(rows)
        pos = self.s["hist_pos"][rows]
        self.s["hist"][pos % self._hist_len, rows] = vals
        self.s["hist_pos"][rows] = pos + 1

    def history(self, i: int) -> np.ndarray:
        """Recent traces of row ``i`` in time order, shape ``(k, n_traces)`` (oldest first)."""
        pos = int(self.s["hist_pos"][i])
        h = self.s["hist"][:, i]
        if pos <= self._hist_len:
            return h[:pos]
        k = pos % self._hist_len
        return np.concatenate([h[k:], h[:k]])

    def energy_cost_basis(self, e_motors: np.ndarray) -> np.ndarray:
        """Electrical energy that the energy term charges, from per-motor energies ``(n, m)`` (J).

        ``regen="clip"``: each motor's energy over the step is clipped at 0 (the
        supply cannot take regenerated energy back; it is burnt in the brake
        chopper), ``regen="count"``: the signed sum (regeneration is credited).
        """
        if self.regen == "clip":
            return np.maximum(e_motors, 0.0).sum(axis=1)
        return e_motors.sum(axis=1)

    # ------------------------------------------------------------------ hooks
    @abstractmethod
    def _reset_rows(self, rows: np.ndarray) -> None:
        """Sample parameters, initial states and references for ``rows`` (use ``self.rngs[i]``)."""

    @abstractmethod
    def _observe(self, rows: np.ndarray) -> np.ndarray:
        """Sensor-based observation of ``rows``, ``(len(rows), n_obs)`` (float64, unclipped)."""

    @abstractmethod
    def _margins(self, rows: np.ndarray) -> dict[str, np.ndarray]:
        """Constraint margins ``margin_*`` of ``rows`` (positive: inside the constraint)."""

    def _traces(self, rows: np.ndarray) -> np.ndarray:
        """Values recorded for the trace plot, ``(len(rows), n_traces)``."""
        return np.zeros((len(rows), 1))

    def draw_mechanism(self, ax: Any, i: int) -> None:
        """Draw row ``i``'s mechanism schematically on the matplotlib axes ``ax`` (default: a label)."""
        ax.text(0.5, 0.5, type(self).__name__, ha="center", va="center", transform=ax.transAxes)


OUT_REWARD, OUT_FAIL, OUT_CLIPPED = range(3)
"""Rows of a compiled step's ``out`` after its ``m`` info rows (``out[m + OUT_*]``); a task's module may
append rows of its own after these (:class:`CompiledStepTask`)."""
STATUS_BAD_ACTION, STATUS_BAD_STATE = -1, -2
"""Return values of a compiled step besides a count of flagged rows: a non-finite action (nothing changed) or
a non-finite new state."""


@register_jitable
def actions_finite(a: np.ndarray) -> bool:
    """All actions finite? (checked by the compiled steps before they change anything)."""
    for i in range(a.shape[0]):
        for k in range(a.shape[1]):
            if not np.isfinite(a[i, k]):
                return False
    return True


@register_jitable
def clip_obs_row(o: np.ndarray, lo: np.ndarray, hi: np.ndarray, obs: np.ndarray, i: int) -> None:
    """``BatchedTask._clip_obs`` of one row: ``o`` clipped in float64, stored into ``obs[i]``."""
    for k in range(o.shape[0]):
        obs[i, k] = min(max(o[k], lo[k]), hi[k])


class CompiledStepTask(BatchedTask):
    """A task whose :meth:`step` runs as one compiled call for all rows (the eLPAS and vsaUT-II tasks).

    The step is written once, as compiled row functions (``NUMBA_DISABLE_JIT=1`` runs them as plain Python).
    Subclasses provide :meth:`_kernel_step`, which advances every row and returns ``out`` ``(n_out, n)``: the
    ``m = len(_info_names)`` info values (``step_info``, then ``reward_<term>``), then the ``OUT_*`` rows.
    This class turns ``out`` into the batched or the single-row result.
    """

    #: the info keys of a step, in ``out``'s order
    step_info: ClassVar[tuple[str, ...]] = ()
    #: info keys whose values are flags (returned as booleans)
    bool_info: ClassVar[tuple[str, ...]] = ()
    _n_info: int
    _info_names: tuple[str, ...]
    _args_memo: tuple[Any, np.ndarray, tuple[Any, ...]] | None = None

    def _init_compiled_step(self) -> None:
        """Set the names of ``out``'s info rows (call at the end of ``__init__``)."""
        self._info_names = (*self.step_info, *(f"reward_{k}" for k in self.reward_terms))
        self._n_info = len(self._info_names)
        self._args_memo = None

    def _build_kernel_args(self) -> tuple[Any, ...]:
        """The arrays the task's compiled step takes between the actions and ``out``."""
        raise NotImplementedError

    def _kernel_args(self) -> tuple[Any, ...]:
        """:meth:`_build_kernel_args`, kept until the parameter set or the state array changes (the state arrays
        are only ever written in place: reset, snapshot restore and the compiled step)."""
        memo = self._args_memo
        if memo is None or memo[0] is not self.params or memo[1] is not self.s["x"]:
            memo = self._args_memo = (self.params, self.s["x"], self._build_kernel_args())
        return memo[2]

    def _run_kernel(self, a: np.ndarray, out: np.ndarray) -> int:
        """Run the task's compiled step on the raw actions ``a`` ``(n, m)``; returns ``STATUS_BAD_ACTION``,
        ``STATUS_BAD_STATE`` (nothing changed) or the task's count of flagged rows."""
        raise NotImplementedError

    def _compiled_call(self, action: Any, n_tail: int) -> tuple[np.ndarray, int]:
        """The compiled step on ``action``: ``(out, status)`` with ``out`` ``(m + n_tail, n)``.  A float array of
        the action shape goes in as it is (the compiled step clips it and checks it is finite); a non-finite
        action raises the ``ValueError`` of :meth:`validate_action`, with nothing changed."""
        n = self.n
        if isinstance(action, np.ndarray) and action.shape == (n, len(self.action_names)) \
                and action.dtype.kind == "f":
            a = action.astype(np.float64, copy=False)
        else:
            a, _ = self.validate_action(action)
        out = np.empty((self._n_info + n_tail, n))
        status = self._run_kernel(a, out)
        if status == STATUS_BAD_ACTION:
            self.validate_action(action)  # raises ValueError naming the component
        return out, status

    def _kernel_step(self, action: Any) -> np.ndarray:
        raise NotImplementedError

    def step(self, action: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict[str, np.ndarray]]:
        """The task's compiled step (drive, core, sensors, energy, margins, reward terms, failures and observation
        of every row in one call); Python draws the noise and renews the signals."""
        out = self._kernel_step(action)
        m = self._n_info
        info = dict(zip(self._info_names, out[:m], strict=True))
        for k in self.bool_info:
            info[k] = info[k] != 0.0
        info["action_clipped"] = out[m + OUT_CLIPPED] != 0.0
        info["time"] = self.s["t"].copy()
        return self.s["obs"].copy(), out[m + OUT_REWARD], out[m + OUT_FAIL] != 0.0, info

    def step_single(self, action: Any) -> tuple[np.ndarray, float, bool, dict[str, Any]]:
        if self.n != 1:
            return super().step_single(action)
        vals = self._kernel_step(action).ravel().tolist()  # (n_out, 1): row 0
        m = self._n_info
        info: dict[str, Any] = dict(zip(self._info_names, vals, strict=False))  # the first m values
        for k in self.bool_info:
            info[k] = info[k] != 0.0
        info["action_clipped"] = vals[m + OUT_CLIPPED] != 0.0
        info["time"] = float(self.s["t"][0])
        return self.s["obs"][0].copy(), vals[m + OUT_REWARD], vals[m + OUT_FAIL] != 0.0, info


class TaskEnv(gym.Env[np.ndarray, np.ndarray]):
    """A single Gymnasium environment over a :class:`BatchedTask` with ``n = 1``.

    Subclasses set ``task_cls``; the constructor's keyword arguments go to it.
    """

    task_cls: ClassVar[type[BatchedTask]]
    metadata: ClassVar[dict[str, Any]] = {"render_modes": ["rgb_array", "human"], "render_fps": 25}
    render_size: ClassVar[tuple[int, int]] = (480, 720)  # (height, width) of rendered frames

    def __init__(self, render_mode: str | None = None, **task_kwargs: Any) -> None:
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode must be one of {self.metadata['render_modes']} or None, got {render_mode!r}")
        self.render_mode = render_mode
        self.task = self.task_cls(1, **task_kwargs)
        self.task.record_history = render_mode is not None
        self.observation_space = self.task.single_observation_space()
        self.action_space = self.task.single_action_space()
        self._renderer: Any = None
        self._rows = np.arange(1)
        self._has_reset = False

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[np.ndarray, dict]:
        super().reset(seed=seed)
        self.task.rngs[0] = self.np_random  # seeded by gym.Env.reset when seed is given, else the running stream
        self.task.reset(self._rows)
        self._has_reset = True
        return self.task.observation()[0], _row_info(self.task.reset_info(self._rows), 0)

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        if not self._has_reset:
            raise RuntimeError("call reset() before step()")
        obs, reward, terminated, info = self.task.step_single(np.asarray(action)[None, ...])
        return obs, reward, terminated, False, info

    def render(self) -> np.ndarray | None:
        if self.render_mode is None:
            gym.logger.warn("render() called without a render_mode; pass render_mode='rgb_array' or 'human'")
            return None
        from vsa_gym.envs.rendering import Renderer

        if self._renderer is None:
            self._renderer = Renderer(self.render_size, title=type(self).__name__)
        frame = self._renderer.draw(self.task, 0)
        if self.render_mode == "human":
            self._renderer.show(frame)
            return None
        return frame

    def close(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None


@numba.njit(cache=True)
def _clip_actions(a: np.ndarray) -> tuple[np.ndarray, np.ndarray, bool]:
    """``(clip(a, -1, 1), rows with a component outside [-1, 1], all finite?)`` for actions ``(n, m)``, one pass."""
    n, m = a.shape
    out = np.empty((n, m))
    clipped = np.zeros(n, dtype=np.bool_)
    finite = True
    for i in range(n):
        for k in range(m):
            v = a[i, k]
            finite = finite and np.isfinite(v)
            clipped[i] = clipped[i] or abs(v) > 1.0
            out[i, k] = min(max(v, -1.0), 1.0)
    return out, clipped, finite


def _row_info(info: Mapping[str, np.ndarray], i: int) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for k, v in info.items():
        x = v[i]
        out[k] = bool(x) if isinstance(x, np.bool_) else float(x)
    return out
