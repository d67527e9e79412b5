"""Soak test: adversarial actions on every registered task, counting non-finite values and how episodes end.

Run::

    python -m benchmarks.soak                 # 10^5 steps per task (all patterns, both control modes, DR on)
    python -m benchmarks.soak --steps 4000    # a CI-sized pass
    python -m benchmarks.soak --json out/soak.json

For every registered id, the native vector environment (``gym.make_vec``, ``--rows`` rows) is driven by each
action pattern in each control mode, with domain randomisation on (+-20 % on three parameters of the device,
resampled at every reset), for an equal share of ``--steps`` env-steps per task.  The patterns are what a
learning agent's exploration or a bug does to an actuator:

* ``extremes``  -- a random corner of the action box per row, switched every 50 steps;
* ``flip``      -- a random corner whose sign flips at every step (the hardest input for the current loops);
* ``bursts``    -- rest, then bursts of 5-100 steps of uniform random full-range actions;
* ``outside``   -- uniform in [-5, 5] per component (outside the box: the envs clip and flag ``action_clipped``).

Counted per (id, mode, pattern): env-steps, non-finite values in observations, rewards and every numeric
``info`` entry (must be 0), episodes ended by ``terminated`` and by which margin (the smallest ``margin_*`` of
the row at the end, ``<= 0`` when a limit was crossed), and episodes truncated by the time limit.
Exits non-zero if any non-finite value was seen.
"""

from __future__ import annotations

import argparse
import json
import time
from collections import Counter
from collections.abc import Callable
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

import vsa_gym  # noqa: F401  (registers the ids)
from vsa_gym.devices.elpas.params import ElpasParams
from vsa_gym.devices.vsaut2.params import VsaUT2Params
from vsa_gym.envs import ENV_IDS
from vsa_gym.envs.randomization import relative_ranges

MODES = ("voltage", "current")
#: +-20 % domain randomisation per device parameter set (paths into it)
RANDOMIZED: dict[type, dict[str, float]] = {
    VsaUT2Params: {"lever.k": 0.2, "I_o": 0.2, "frame_motor.R": 0.2},
    ElpasParams: {"friction.F_c": 0.2, "motor.R": 0.2, "drive.J_r": 0.2},
}

Pattern = Callable[[np.random.Generator, int, int, int, np.ndarray], np.ndarray]


def _extremes(rng: np.random.Generator, k: int, n: int, d: int, state: np.ndarray) -> np.ndarray:
    if k % 50 == 0:
        state[:] = rng.choice([-1.0, 1.0], size=(n, d))
    return state.copy()


def _flip(rng: np.random.Generator, k: int, n: int, d: int, state: np.ndarray) -> np.ndarray:
    if k == 0:
        state[:] = rng.choice([-1.0, 1.0], size=(n, d))
    return state * (1.0 if k % 2 == 0 else -1.0)


def _bursts(rng: np.random.Generator, k: int, n: int, d: int, state: np.ndarray) -> np.ndarray:
    # state[:, 0]: steps left in the current burst (> 0) or rest (< 0)
    left = state[:, 0]
    renew = left == 0
    if np.any(renew):
        lengths = rng.integers(5, 101, size=n).astype(float)
        burst = rng.random(n) < 0.5
        left[renew] = np.where(burst, lengths, -lengths)[renew]
    a = np.where((left > 0)[:, None], rng.uniform(-1.0, 1.0, size=(n, d)), 0.0)
    left -= np.sign(left)
    return a


def _outside(rng: np.random.Generator, k: int, n: int, d: int, state: np.ndarray) -> np.ndarray:
    return rng.uniform(-5.0, 5.0, size=(n, d))


PATTERNS: dict[str, Pattern] = {"extremes": _extremes, "flip": _flip, "bursts": _bursts, "outside": _outside}


def randomization_for(env_id: str) -> dict[str, tuple[float, float]]:
    """The +-20 % ranges around the nominal parameters of ``env_id``'s device."""
    env = gym.make_vec(env_id, num_envs=1)
    params = env.unwrapped.task.base_rows[0]
    env.close()
    if type(params) not in RANDOMIZED:
        raise KeyError(f"no randomisation declared for {type(params).__name__} ({env_id}); add it to RANDOMIZED")
    return relative_ranges(params, RANDOMIZED[type(params)])


def _non_finite(obs: Any, reward: np.ndarray, info: dict[str, Any]) -> int:
    bad = int(np.count_nonzero(~np.isfinite(np.asarray(obs, dtype=np.float64))))
    bad += int(np.count_nonzero(~np.isfinite(reward)))
    for key, v in info.items():
        if key.startswith("_"):
            continue
        a = np.asarray(v)
        if a.dtype.kind == "f":
            bad += int(np.count_nonzero(~np.isfinite(a)))
    return bad


def soak_one(env_id: str, mode: str, pattern: str, steps: int, rows: int, seed: int,
             ranges: dict[str, tuple[float, float]]) -> dict[str, Any]:
    """Drive ``rows`` rows of ``env_id`` for about ``steps`` env-steps with one action pattern, the parameters
    randomised over ``ranges`` (:func:`randomization_for`)."""
    env = gym.make_vec(env_id, num_envs=rows, control_mode=mode, domain_randomization=ranges)
    rng = np.random.default_rng(seed)
    d = int(np.prod(env.single_action_space.shape))
    state = np.zeros((rows, d))
    obs, info = env.reset(seed=seed)
    bad = _non_finite(obs, np.zeros(rows), info)
    ends: Counter[str] = Counter()
    truncated_n = 0
    n_steps = max(1, steps // rows)
    t0 = time.perf_counter()
    for k in range(n_steps):
        action = PATTERNS[pattern](rng, k, rows, d, state)
        obs, reward, terminated, truncated, info = env.step(action.astype(np.float32))
        bad += _non_finite(obs, np.asarray(reward, dtype=np.float64), info)
        done = np.asarray(terminated, dtype=bool)
        truncated_n += int(np.count_nonzero(np.asarray(truncated, dtype=bool) & ~done))
        if np.any(done):
            margins = {key: np.asarray(v, dtype=np.float64) for key, v in info.items() if key.startswith("margin_")}
            for i in np.flatnonzero(done):
                if margins:
                    key = min(margins, key=lambda m, i=i: float(margins[m][i]))
                    ends[key.removeprefix("margin_") if margins[key][i] <= 0.0 else f"{key} > 0"] += 1
                else:
                    ends["terminated"] += 1
    wall = time.perf_counter() - t0
    env.close()
    return {"id": env_id, "mode": mode, "pattern": pattern, "env_steps": n_steps * rows, "non_finite": bad,
            "terminated": int(sum(ends.values())), "ended_by": dict(sorted(ends.items())),
            "truncated": truncated_n, "steps_per_s": n_steps * rows / wall}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--steps", type=int, default=100_000, help="env-steps per task, shared by modes and patterns")
    ap.add_argument("--rows", type=int, default=4,
                    help="rows of the vector environment (few rows: long episodes, so time limits are reached)")
    ap.add_argument("--ids", nargs="*", default=list(ENV_IDS))
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", type=Path, default=None)
    a = ap.parse_args(argv)
    share = a.steps // (len(MODES) * len(PATTERNS))
    results = []
    print(f"{'id':38s} {'mode':8s} {'pattern':9s} {'steps':>7s} {'non-finite':>10s} {'ended':>6s} {'trunc':>6s}"
          "  ended by")
    for env_id in a.ids:
        ranges = randomization_for(env_id)
        for mode in MODES:
            for j, pattern in enumerate(PATTERNS):
                r = soak_one(env_id, mode, pattern, share, a.rows, a.seed + 1000 * j, ranges)
                results.append(r)
                by = ", ".join(f"{k} {v}" for k, v in r["ended_by"].items()) or "-"
                print(f"{env_id:38s} {mode:8s} {pattern:9s} {r['env_steps']:7d} {r['non_finite']:10d} "
                      f"{r['terminated']:6d} {r['truncated']:6d}  {by}", flush=True)
    total_bad = sum(r["non_finite"] for r in results)
    print(f"non-finite values in total: {total_bad}")
    if a.json:
        a.json.parent.mkdir(parents=True, exist_ok=True)
        a.json.write_text(json.dumps({"steps_per_task": a.steps, "rows": a.rows, "results": results}, indent=2) + "\n")
    return 1 if total_bad else 0


if __name__ == "__main__":
    raise SystemExit(main())
