"""Drive one ``gym.make`` environment for profiling the single-env hot path (``env.step``).

    python -m benchmarks.profile_env ID N [SEED] [CONTROL_DT]
    py-spy record -f raw -r 250 -o OUT -- python -m benchmarks.profile_env ID N
    python -m cProfile -s tottime -m benchmarks.profile_env vsa_gym/VsaUT2-PositionStiffness-v0 3000 0 1e-3

Seeds the env, takes 20 warm-up steps (numba's cache load happens there), then ``N`` steps with seeded random
actions in ``[-1, 1]`` (drawn beforehand, so the sampler is not profiled), resetting at episode ends, and
prints the env-steps per CPU second of those ``N`` steps.  ``CONTROL_DT`` (s) overrides the env's control step.
"""

from __future__ import annotations

import sys
import time

import gymnasium as gym
import numpy as np

import vsa_gym  # noqa: F401  (registers the ids)


def run(env_id: str, n: int, seed: int = 0, control_dt: float | None = None) -> float:
    """Env-steps per CPU second of ``n`` steps of ``env_id`` (after 20 warm-up steps)."""
    env = gym.make(env_id, **({} if control_dt is None else {"control_dt": control_dt}))
    env.reset(seed=seed)
    dim = env.action_space.shape[0]
    acts = np.random.default_rng(seed).uniform(-1.0, 1.0, (n + 20, dim)).astype(np.float32)
    for k in range(20):
        env.step(acts[k])
    t0 = time.process_time()
    for k in range(n):
        _, _, term, trunc, _ = env.step(acts[20 + k])
        if term or trunc:
            env.reset()
    rate = n / (time.process_time() - t0)
    env.close()
    return rate


def main(argv: list[str] | None = None) -> None:
    args = sys.argv[1:] if argv is None else argv
    if len(args) < 2:
        raise SystemExit(__doc__)
    env_id, n = args[0], int(args[1])
    seed = int(args[2]) if len(args) > 2 else 0
    control_dt = float(args[3]) if len(args) > 3 else None
    print(f"{env_id}: {run(env_id, n, seed, control_dt):.0f} env-steps per CPU s")


if __name__ == "__main__":
    main()
