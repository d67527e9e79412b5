"""Throw baselines for ``VsaUT2-Throw-v0``: the best fixed-stiffness throw and an optimal-control throw.

Both are open-loop action schedules on the full model (the environment itself: its drives, limits, I^2 t foldback
and energy budget), held piecewise constant over segments of ``segment_steps`` control steps; after the last
segment the command is zero.  They answer the question the Throw task asks -- what does varying the stiffness buy
-- the way Braun, Howard & Vijayakumar (2012, "Optimal variable stiffness control: formulation and application to
explosive movement tasks") do: the best throw at any *fixed* stiffness against a throw optimised over *both*
motors.

(a) :func:`fixed_stiffness_search` -- the stiffness is held: the pivot starts at ``initial_q1_fraction`` of its
    stroke and its motor is commanded 0 (the lead screw holds it; the drift is reported); the frame is driven
    bang-bang, ``+a`` until segment ``k1``, ``-a`` until ``k2``, ``+a`` after (the wind-up / whip structure of an
    explosive throw; ``k1 = k2`` is a plain push).  A grid over the stiffness (pivot position), the level ``a``
    (full voltage spends the 5 J budget on copper losses in 50 ms, so the level is searched too) and the switch
    segments, evaluated in batches on the native vector env; the best throw is the highest release speed.
(b) :func:`optimal_throw` -- direct single shooting: both motors' piecewise-constant commands (``2 n_segments``
    values in ``[-1, 1]``) maximise the release speed with scipy's L-BFGS-B, started from (a)'s throw and from the
    best fixed-stiffness throws at other pivot positions, with and without a pivot kick (:func:`throw_starts`:
    single shooting finds the optimum near its start, so several starts); gradients by forward differences, all
    ``2 n_segments + 1`` rollouts of one gradient in one batched call.  The objective is
    the release speed of a throw that releases, and ``(max r - release_angle) / release_angle`` (< 0) of one that
    does not, so the search is led back to releasing.  The pivot may move: the stiffness varies during the throw.

Run ``python -m benchmarks.throw_baselines`` for the numbers (``docs/throw_baselines.json``).
"""

from __future__ import annotations

import dataclasses
import itertools
from collections.abc import Mapping, Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from scipy.optimize import minimize

import vsa_gym  # noqa: F401  (registers the ids)
from vsa_gym.devices.vsaut2.layout import STATE

THROW = "vsa_gym/VsaUT2-Throw-v0"
R_COLUMN, TH1_COLUMN = STATE["r"], STATE["th1"]  # the output angle; the pivot motor angle (a held stiffness' drift)


@dataclasses.dataclass(frozen=True)
class ThrowOutcome:
    """What a batch of schedules did, one entry per schedule."""

    released: np.ndarray  # bool
    release_speed: np.ndarray  # rad/s (0 where not released)
    energy_J: np.ndarray  # energy charged against the budget when the episode ended (J)
    release_time_s: np.ndarray  # s (nan where not released)
    peak_r: np.ndarray  # rad, highest output angle reached
    pivot_drift: np.ndarray  # rad of the pivot motor, largest |th1 - th1(0)| (the held stiffness' drift)

    def score(self, release_angle: float) -> np.ndarray:
        """The objective: release speed if released, else ``(peak_r - release_angle) / release_angle`` (< 0)."""
        return np.where(self.released, self.release_speed, (self.peak_r - release_angle) / release_angle)


@dataclasses.dataclass(frozen=True)
class ThrowResult:
    """One baseline's best schedule and what it did."""

    name: str
    actions: np.ndarray  # (n_segments, 2) in [-1, 1]
    segment_steps: int
    initial_q1_fraction: float
    release_speed: float
    energy_J: float
    release_time_s: float
    pivot_drift: float
    evaluations: int
    details: Mapping[str, Any] = dataclasses.field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        d = dataclasses.asdict(self)
        d["actions"] = self.actions.tolist()
        d["details"] = dict(self.details)
        return d


def rollout(actions: np.ndarray, segment_steps: int, *, initial_q1_fraction: float = 0.5,
            env_kwargs: Mapping[str, Any] | None = None, seed: int = 0) -> ThrowOutcome:
    """Run the schedules ``actions`` ``(m, n_segments, 2)`` on ``m`` rows of the Throw vector env, to each row's
    first episode end (release, failure or time limit)."""
    actions = np.asarray(actions, dtype=np.float64)
    if actions.ndim != 3 or actions.shape[2] != 2:
        raise ValueError(f"actions must have shape (m, n_segments, 2), got {actions.shape}")
    if not np.all(np.isfinite(actions)):
        raise ValueError("actions must be finite")
    m, n_seg, _ = actions.shape
    kw = {"initial_q1_fraction": initial_q1_fraction, **dict(env_kwargs or {})}
    env = gym.make_vec(THROW, num_envs=m, **kw)
    task = env.unwrapped.task
    env.reset(seed=[seed] * m)
    th1_0 = task.s["x"][:, TH1_COLUMN].copy()
    dt = float(task.control_dt)
    done = np.zeros(m, dtype=bool)
    released = np.zeros(m, dtype=bool)
    speed, energy = np.zeros(m), np.zeros(m)
    t_rel = np.full(m, np.nan)
    peak_r = task.s["x"][:, R_COLUMN].copy()
    drift = np.zeros(m)
    k = 0
    while not done.all():
        seg = k // segment_steps
        a = actions[:, seg, :] if seg < n_seg else np.zeros((m, 2))
        _, _, term, trunc, info = env.step(a.astype(np.float32))
        live = ~done
        x = task.s["x"]
        # rows that ended this step were reset by the env after the step (next-step autoreset keeps the state)
        peak_r[live] = np.maximum(peak_r[live], x[live, R_COLUMN])
        drift[live] = np.maximum(drift[live], np.abs(x[live, TH1_COLUMN] - th1_0[live]))
        end = live & (np.asarray(term) | np.asarray(trunc))
        rel = end & np.asarray(info["released"], dtype=bool)
        released[rel] = True
        speed[rel] = np.asarray(info["release_speed"])[rel]
        t_rel[rel] = (k + 1) * dt
        energy[end] = np.asarray(info["energy_charged_total"])[end]
        done |= end
        k += 1
    env.close()
    return ThrowOutcome(released, speed, energy, t_rel, peak_r, drift)


def bang_bang(n_segments: int, level: float, k1: int, k2: int) -> np.ndarray:
    """The fixed-stiffness schedule ``(n_segments, 2)``: pivot 0, frame ``+level`` / ``-level`` / ``+level`` with
    switches at segments ``k1 <= k2``."""
    a = np.zeros((n_segments, 2))
    a[:, 1] = level
    a[k1:k2, 1] = -level
    return a


def fixed_stiffness_search(q1_fractions: Sequence[float] = (0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9),
                           levels: Sequence[float] = (0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0),
                           switches: Sequence[int] = (0, 2, 4, 6, 8, 10, 12, 16),
                           n_segments: int = 30, segment_steps: int = 10, refine: float = 0.05,
                           env_kwargs: Mapping[str, Any] | None = None) -> ThrowResult:
    """Baseline (a): the best bang-bang frame throw over a grid of held stiffnesses (pivot positions), levels and
    switch segments, then the same switch grid at the best stiffness and level moved by ``+-refine`` (each
    combination)."""
    pairs = [(k1, k2) for k1, k2 in itertools.product(switches, switches) if k1 <= k2 and (k1 > 0 or k2 == 0)]
    best: tuple[float, float, float, int, int, ThrowOutcome] | None = None
    per_stiffness: dict[str, tuple[float, float, int, int]] = {}  # q1 fraction -> (speed, level, k1, k2)
    evaluations = 0

    def search(fractions: Sequence[float], lvls: Sequence[float]) -> None:
        nonlocal best, evaluations
        grid = [(lv, k1, k2) for lv in lvls for k1, k2 in pairs]
        schedules = np.stack([bang_bang(n_segments, lv, k1, k2) for lv, k1, k2 in grid])
        for f in fractions:
            out = rollout(schedules, segment_steps, initial_q1_fraction=f, env_kwargs=env_kwargs)
            evaluations += len(grid)
            j = int(np.argmax(np.where(out.released, out.release_speed, -np.inf)))
            speed = float(out.release_speed[j]) if out.released[j] else 0.0
            if speed > per_stiffness.get(f"{f:.3f}", (0.0,))[0]:
                per_stiffness[f"{f:.3f}"] = (speed, *grid[j])
            if out.released[j] and (best is None or speed > best[0]):
                best = (speed, f, grid[j][0], grid[j][1], grid[j][2], _row(out, j))

    search(q1_fractions, levels)
    if best is None:
        raise RuntimeError("no fixed-stiffness schedule of the grid released")
    _, f0, lv0 = best[:3]
    if refine > 0.0:
        search([min(max(f0 + d, 0.0), 1.0) for d in (-refine, 0.0, refine)],
               [min(max(lv0 + d, 0.05), 1.0) for d in (-refine, 0.0, refine)])
    speed, f, lv, k1, k2, out = best
    return ThrowResult("fixed stiffness, bang-bang frame (grid search)", bang_bang(n_segments, lv, k1, k2),
                       segment_steps, f, speed, float(out.energy_J[0]), float(out.release_time_s[0]),
                       float(out.pivot_drift[0]), evaluations,
                       {"level": lv, "switch_segments": [k1, k2],
                        "best_per_q1_fraction": {
                            k: {"release_speed": v[0], "level": v[1], "switch_segments": [v[2], v[3]]}
                            for k, v in sorted(per_stiffness.items())}})


def _row(out: ThrowOutcome, j: int) -> ThrowOutcome:
    """Entry ``j`` of a batch outcome as a batch of one."""
    return ThrowOutcome(*(np.asarray(getattr(out, f.name))[j:j + 1] for f in dataclasses.fields(out)))


def throw_starts(fixed: ThrowResult, n_stiffness: int = 3, pivot_kicks: Sequence[float] = (0.5, -0.5)
                 ) -> list[tuple[np.ndarray, float]]:
    """Starting schedules for :func:`optimal_throw`: the best fixed-stiffness throws at the ``n_stiffness`` best
    pivot positions of the search, each as found and with the pivot driven at ``pivot_kicks`` over the first
    third of the schedule (seeds of a varying stiffness; single shooting only finds the optimum near its start)."""
    n_seg = fixed.actions.shape[0]
    ranked = sorted(fixed.details["best_per_q1_fraction"].items(), key=lambda kv: -kv[1]["release_speed"])
    starts = []
    for key, best in ranked[:n_stiffness]:
        if best["release_speed"] <= 0.0:
            continue
        base = bang_bang(n_seg, best["level"], *best["switch_segments"])
        starts.append((base, float(key)))
        for kick in pivot_kicks:
            kicked = base.copy()
            kicked[: n_seg // 3, 0] = kick
            starts.append((kicked, float(key)))
    return starts


def optimal_throw(start: ThrowResult, *, starts: Sequence[tuple[np.ndarray, float]] = (), max_iter: int = 60,
                  eps: float = 1e-3, env_kwargs: Mapping[str, Any] | None = None,
                  release_angle: float = 0.3) -> ThrowResult:
    """Baseline (b): both motors' piecewise-constant commands optimised by direct single shooting (L-BFGS-B,
    forward-difference gradients in one batched rollout), from ``start``'s schedule and pivot position and from
    every ``(schedule, q1_fraction)`` of ``starts`` (e.g. :func:`throw_starts`); the fastest release wins, and it
    is never slower than ``start``."""
    seg_steps = start.segment_steps
    calls = [0]
    runs = []
    for actions, f0 in [(start.actions, start.initial_q1_fraction), *starts]:
        shape, n = actions.shape, actions.size
        cache: dict[bytes, tuple[float, np.ndarray]] = {}

        def value_and_grad(theta: np.ndarray, shape: tuple[int, ...] = shape, n: int = n, f0: float = f0,
                           cache: dict[bytes, tuple[float, np.ndarray]] = cache) -> tuple[float, np.ndarray]:
            key = theta.tobytes()
            if key not in cache:
                base = np.clip(theta, -1.0, 1.0)
                # forward differences inward from the bounds, so every probe stays in [-1, 1]
                step = np.where(base + eps > 1.0, -eps, eps)
                probes = np.repeat(base[None, :], n + 1, axis=0)
                probes[np.arange(1, n + 1), np.arange(n)] += step
                out = rollout(probes.reshape(n + 1, *shape), seg_steps, initial_q1_fraction=f0, env_kwargs=env_kwargs)
                s = out.score(release_angle)
                calls[0] += n + 1
                cache.clear()
                cache[key] = (-float(s[0]), -(s[1:] - s[0]) / step)
            return cache[key]

        res = minimize(value_and_grad, actions.ravel(), jac=True, method="L-BFGS-B", bounds=[(-1.0, 1.0)] * n,
                       options={"maxiter": max_iter})
        best = np.clip(res.x, -1.0, 1.0).reshape(shape)
        out = rollout(best[None], seg_steps, initial_q1_fraction=f0, env_kwargs=env_kwargs)
        speed = float(out.release_speed[0]) if out.released[0] else 0.0
        runs.append((speed, best, f0, out, int(res.nit)))
    speed, best, f0, out, _ = max(runs, key=lambda r: r[0])
    if speed < start.release_speed:  # never worse than its start
        best, f0 = start.actions, start.initial_q1_fraction
        out = rollout(best[None], seg_steps, initial_q1_fraction=f0, env_kwargs=env_kwargs)
    return ThrowResult("optimal control, both motors (direct single shooting, L-BFGS-B)", best, seg_steps, f0,
                       float(out.release_speed[0]), float(out.energy_J[0]), float(out.release_time_s[0]),
                       float(out.pivot_drift[0]), calls[0],
                       {"starts": len(runs), "release_speed_per_start": [r[0] for r in runs],
                        "iterations_per_start": [r[4] for r in runs]})


class SchedulePolicy:
    """An open-loop schedule as a policy for :func:`baselines.metrics.evaluate_policy` (the observation is
    ignored; the step count restarts at :meth:`reset`)."""

    def __init__(self, actions: np.ndarray, segment_steps: int) -> None:
        self.actions, self.segment_steps = np.asarray(actions, dtype=np.float64), int(segment_steps)
        self.k = 0

    def reset(self) -> None:
        self.k = 0

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        n = np.atleast_2d(obs).shape[0]
        seg = self.k // self.segment_steps
        self.k += 1
        a = self.actions[seg] if seg < len(self.actions) else np.zeros(2)
        return np.repeat(a[None, :], n, axis=0).astype(np.float32)


SCHEDULE_LABELS = {"fixed_stiffness": "(a) fixed stiffness, bang-bang", "optimal_control": "(b) optimal control"}
"""Keys of the throw-baseline record (``python -m benchmarks.throw_baselines`` -> ``docs/throw_baselines.json``)
and the names the comparison tables give them."""


def schedule_factory(entry: Mapping[str, Any]) -> tuple[Any, dict[str, Any]]:
    """``(policy_factory, env_kwargs)`` that replay one recorded schedule (an entry of the throw-baseline record or
    :meth:`ThrowResult.to_dict`) under :func:`baselines.metrics.evaluate_policy`: the schedule's start stiffness is
    an environment argument (``initial_q1_fraction``), chosen by the search, the agents start at the default."""
    actions, segment_steps = np.asarray(entry["actions"], dtype=np.float64), int(entry["segment_steps"])
    return (lambda env: SchedulePolicy(actions, segment_steps)), {
        "initial_q1_fraction": float(entry["initial_q1_fraction"])}
