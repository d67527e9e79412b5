"""One evaluation protocol for baselines and agents: run a policy on an env id over fixed seeds.

``evaluate_policy(env_id, policy_factory, seeds)`` builds the native vector environment
(one row per seed; row ``i`` is the episode a single environment reset with ``seeds[i]``
would give), calls ``policy_factory(env)`` once, ``policy.reset()`` if it has one, then feeds
the batched observations ``(n, n_obs)`` to ``policy(obs) -> actions (n, n_act)`` until the
episode length or the end of every episode.  Steps after a row's episode ended are ignored.

The row it returns (a flat dict, means over the episodes):

* tracking RMS in physical units: ``force_rms_N`` (force tracking), ``position_rms_rad`` and
  ``log_stiffness_rms`` (RMS of ``ln K - ln K_ref``; ``stiffness_rel_rms`` = ``exp(.) - 1``)
  (vsaUT-II position/stiffness); the quarter car's comfort metric ``comfort_aw_rms``
  (ISO 2631-1 W_k-weighted RMS body acceleration, m/s^2, from the env's causal filter) with
  ``travel_rms_m`` and ``tyre_load_rms`` (dynamic tyre force / static);
* ``energy_J`` (signed electrical energy from the supply), ``energy_charged_J`` (regeneration
  clipped per step, the env's energy-term basis), ``peak_power_W`` (largest per-step mean
  electrical power);
* ``violations`` (episodes ended by a constraint, not by a Throw's release: end stop, I^2 t trip, tyre lift-off, bump
  stop) and ``violation_steps`` (steps with any ``margin_*`` <= 0, summed over episodes);
* ``steps`` (mean episode length), ``return`` (mean episode return), ``metric`` (name of the
  environment's primary tracking metric, :data:`PRIMARY_METRIC`) and ``metric_value``;
* ``per_episode``: the same metrics as lists, one entry per seed (row order), e.g. to split a
  :class:`MixedPolicy` run;
* with ``return_traces=True``, ``traces``: per step ``(n, T)`` arrays of the tracking errors; with
  ``return_traces="all"`` also every ``margin_*`` and ``reward_*`` entry and ``energy_el_total`` of ``info``,
  ``terminated`` (1 at the step that ended the episode without the time limit), and ``obs`` / ``action``
  ``(n, T, dim)`` (the observation after the step and the action that led to it); NaN after a row's episode ended.

Policies may also be given per row: any callable on ``(n, n_obs)``.  :class:`ZeroPolicy` and
:class:`RandomPolicy` are the reference policies the tests compare the baselines with.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import gymnasium as gym
import numpy as np

import vsa_gym  # noqa: F401  (registers the ids)

PRIMARY_METRIC: dict[str, str] = {
    "vsa_gym/ELPAS-ForceTracking-v0": "force_rms_N",
    "vsa_gym/ELPAS-QuarterCar-v0": "comfort_aw_rms",
    "vsa_gym/VsaUT2-PositionStiffness-v0": "position_rms_rad",
    "vsa_gym/VsaUT2-Throw-v0": "return",
}
"""The tracking metric each environment is judged by (lower is better, except ``return``)."""

ERROR_TRACES = ("force_error", "position_error", "log_stiffness_error", "weighted_accel")
"""``info`` entries that ``return_traces=True`` keeps per step."""
TRACE_KEYS = ("energy_el_total",)
TRACE_PREFIXES = ("margin_", "reward_")
"""``info`` entries that ``return_traces="all"`` keeps as well (besides the observation, action and end flag)."""

Policy = Callable[[np.ndarray], np.ndarray]
PolicyFactory = Callable[[Any], Policy]


class ZeroPolicy:
    """Always the zero action (no voltage / no current)."""

    def __init__(self, n_act: int) -> None:
        self.n_act = n_act

    def reset(self) -> None:
        pass

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        o = np.atleast_2d(obs)
        return np.zeros((o.shape[0], self.n_act), dtype=np.float32)


class RandomPolicy:
    """Uniform random actions in ``[-1, 1]`` from a seeded generator."""

    def __init__(self, n_act: int, seed: int = 0) -> None:
        self.n_act, self.seed = n_act, seed
        self.reset()

    def reset(self) -> None:
        self.rng = np.random.default_rng(self.seed)

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        o = np.atleast_2d(obs)
        return self.rng.uniform(-1.0, 1.0, (o.shape[0], self.n_act)).astype(np.float32)


def zero_policy_factory(env: Any) -> ZeroPolicy:
    return ZeroPolicy(int(env.single_action_space.shape[0]))


def random_policy_factory(env: Any, seed: int = 0) -> RandomPolicy:
    return RandomPolicy(int(env.single_action_space.shape[0]), seed)


class MixedPolicy:
    """Several policies side by side on one vector environment: ``parts[k]`` drives ``counts[k]`` consecutive rows.

    Build it with :func:`mixed_policy_factory` to compare policies in one batched run (the rows of
    :func:`evaluate_policy`'s ``per_episode`` lists follow the same order).
    """

    def __init__(self, parts: list[Any], counts: Sequence[int]) -> None:
        self.parts = parts
        edges = np.concatenate([[0], np.cumsum(counts)])
        self.slices = [slice(int(a), int(b)) for a, b in zip(edges[:-1], edges[1:], strict=True)]

    def reset(self) -> None:
        for p in self.parts:
            if hasattr(p, "reset"):
                p.reset()

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        return np.concatenate([np.asarray(p(obs[sl]), dtype=np.float32).reshape(sl.stop - sl.start, -1)
                               for p, sl in zip(self.parts, self.slices, strict=True)], axis=0)


def mixed_policy_factory(factories: Sequence[PolicyFactory], counts: Sequence[int]) -> PolicyFactory:
    """``policy_factory(env)`` of a :class:`MixedPolicy` (each factory is called with the same env)."""

    def make(env: Any) -> MixedPolicy:
        return MixedPolicy([f(env) for f in factories], counts)

    return make


def evaluate_policy(env_id: str, policy_factory: PolicyFactory, seeds: Sequence[int],
                    episode_steps: int | None = None, env_kwargs: Mapping[str, Any] | None = None,
                    return_traces: bool | str = False) -> dict[str, Any]:
    """Run ``policy_factory(env)`` on ``env_id`` for one episode per seed (see the module docstring)."""
    seeds = [int(s) for s in seeds]
    if not seeds:
        raise ValueError("seeds: need at least one seed")
    if return_traces not in (False, True, "all"):
        raise ValueError(f"return_traces must be False, True or 'all', got {return_traces!r}")
    env = gym.make_vec(env_id, num_envs=len(seeds), **dict(env_kwargs or {}))
    try:
        return _run(env, env_id, policy_factory, seeds, episode_steps, return_traces)
    finally:
        env.close()


def _run(env: Any, env_id: str, policy_factory: PolicyFactory, seeds: list[int], episode_steps: int | None,
         return_traces: bool | str) -> dict[str, Any]:
    n = len(seeds)
    limit = env.spec.max_episode_steps if env.spec is not None else None
    steps = int(episode_steps or limit or 1000)
    if limit is not None and steps > limit:
        raise ValueError(f"episode_steps={steps} exceeds the time limit {limit} of {env_id}")
    dt = float(env.unwrapped.task.control_dt)
    policy = policy_factory(env)
    obs, _ = env.reset(seed=seeds)
    if hasattr(policy, "reset"):
        policy.reset()
    alive = np.ones(n, dtype=bool)
    length = np.zeros(n)
    ret = np.zeros(n)
    sums: dict[str, np.ndarray] = {}
    peak = np.full(n, -np.inf)
    violations = np.zeros(n)
    viol_steps = np.zeros(n)
    traces: dict[str, list[np.ndarray]] = {}

    def acc(key: str, v: np.ndarray) -> None:
        sums[key] = sums.get(key, np.zeros(n)) + np.where(alive, v, 0.0)

    for _ in range(steps):
        a = np.asarray(policy(obs), dtype=np.float32).reshape(n, -1)
        obs, rew, term, trunc, info = env.step(a)
        e = np.asarray(info["energy_el"], dtype=np.float64)
        acc("energy_el", e)
        acc("energy_charged", np.asarray(info["energy_charged"], dtype=np.float64))
        peak = np.where(alive, np.maximum(peak, e / dt), peak)
        ret += np.where(alive, rew, 0.0)
        for key, name in (("force_error", "force_sq"), ("position_error", "position_sq"),
                          ("log_stiffness_error", "logk_sq"), ("weighted_accel", "aw_sq"),
                          ("suspension_travel", "travel_sq")):
            if key in info:
                acc(name, np.asarray(info[key], dtype=np.float64) ** 2)
        if "tyre_force" in info:
            p = env.unwrapped.task.params
            F0 = (np.asarray(p.car.m_s) + np.asarray(p.car.m_u)) * 9.81
            acc("tyre_sq", (np.asarray(info["tyre_force"]) / F0 - 1.0) ** 2)
        bad = np.zeros(n, dtype=bool)
        for key, v in info.items():
            if key.startswith("margin_") and not key.startswith("_"):
                bad |= np.asarray(v, dtype=np.float64) <= 0.0
        viol_steps += np.where(alive, bad, 0)
        # a Throw episode also ends on success (the release): that is not a violation
        success = np.asarray(info["released"], dtype=bool) if "released" in info else np.zeros(n, dtype=bool)
        violations += np.where(alive & np.asarray(term) & ~success, 1, 0)
        length += alive
        if return_traces:
            full = return_traces == "all"
            keys = [k for k in info
                    if k in ERROR_TRACES or (full and (k.startswith(TRACE_PREFIXES) or k in TRACE_KEYS))]
            for key in keys:
                traces.setdefault(key, []).append(np.where(alive, np.asarray(info[key], dtype=np.float64), np.nan))
            if full:
                traces.setdefault("obs", []).append(np.where(alive[:, None], np.asarray(obs, dtype=np.float64),
                                                             np.nan))
                traces.setdefault("action", []).append(np.where(alive[:, None], a.astype(np.float64), np.nan))
                traces.setdefault("terminated", []).append(np.where(alive, np.asarray(term, dtype=np.float64),
                                                                    np.nan))
        alive &= ~(np.asarray(term) | np.asarray(trunc))
        if not alive.any():
            break

    L = np.maximum(length, 1.0)
    row: dict[str, Any] = {"env_id": env_id, "episodes": n, "seeds": seeds, "steps": float(length.mean()),
                           "return": float(ret.mean())}

    per: dict[str, list[float]] = {}

    def rms(name: str) -> float:
        v = np.sqrt(sums[name] / L)
        return float(np.mean(v))

    for key, name in (("force_rms_N", "force_sq"), ("position_rms_rad", "position_sq"),
                      ("log_stiffness_rms", "logk_sq"), ("comfort_aw_rms", "aw_sq"), ("travel_rms_m", "travel_sq"),
                      ("tyre_load_rms", "tyre_sq")):
        if name in sums:
            per[key] = np.sqrt(sums[name] / L).tolist()
    per["energy_J"] = sums["energy_el"].tolist()
    per["peak_power_W"] = peak.tolist()
    per["violations"] = violations.astype(int).tolist()
    per["steps"] = length.tolist()

    if "force_sq" in sums:
        row["force_rms_N"] = rms("force_sq")
    if "position_sq" in sums:
        row["position_rms_rad"] = rms("position_sq")
        row["log_stiffness_rms"] = rms("logk_sq")
        row["stiffness_rel_rms"] = float(np.exp(row["log_stiffness_rms"]) - 1.0)
    if "aw_sq" in sums:
        row["comfort_aw_rms"] = rms("aw_sq")
        row["travel_rms_m"] = rms("travel_sq")
        row["tyre_load_rms"] = rms("tyre_sq")
    row["energy_J"] = float(np.mean(sums["energy_el"]))
    row["energy_charged_J"] = float(np.mean(sums["energy_charged"]))
    row["peak_power_W"] = float(np.mean(peak))
    row["violations"] = int(violations.sum())
    row["violation_steps"] = int(viol_steps.sum())
    row["metric"] = PRIMARY_METRIC.get(env_id, "return")
    row["metric_value"] = row[row["metric"]]
    row["per_episode"] = per
    if return_traces:
        row["traces"] = {k: np.stack(v, axis=1) for k, v in traces.items()}
    return row
