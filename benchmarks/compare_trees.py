"""Env-step speed of two checkouts of this project, measured alternately in one run (for refactors).

Run::

    git worktree add /tmp/before <commit>          # the code before the change
    python -m benchmarks.compare_trees /tmp/before . [--rounds 5] [--json FILE]

For every registered id, as a single environment (``gym.make``, random valid actions, resets included) and as
a native vector environment of 64 rows, each tree's code runs in its own fresh interpreter (``cwd`` = the tree,
so ``import vsa_gym`` is that tree's), rounds alternating between the trees so that load on a shared machine
hits both alike.  A round compiles (or loads the numba cache) first and then times a fixed number of steps; the
best round of each tree counts.  Prints steps/s of both and the ratio after/before (> 1: the change is faster).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

IDS = ("vsa_gym/VsaUT2-PositionStiffness-v0", "vsa_gym/VsaUT2-Throw-v0", "vsa_gym/ELPAS-ForceTracking-v0",
       "vsa_gym/ELPAS-QuarterCar-v0")

PROBE = r"""
import json, sys, time
import gymnasium as gym
import numpy as np
import vsa_gym  # noqa: F401
env_id, n, steps = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
if n == 1:
    env = gym.make(env_id)
else:
    env = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point")
rng = np.random.default_rng(0)
shape = env.action_space.shape
def run(k):
    env.reset(seed=0)
    t0 = time.perf_counter()
    for _ in range(k):
        _, _, term, trunc, _ = env.step(rng.uniform(-1, 1, size=shape).astype(np.float32))
        if n == 1 and (term or trunc):
            env.reset()
    return time.perf_counter() - t0
run(50)  # compile / load the cache
best = min(run(steps) for _ in range(3))
print(json.dumps({"steps_per_s": steps * n / best}))
"""


def probe(tree: Path, env_id: str, n: int, steps: int) -> float:
    res = subprocess.run([sys.executable, "-c", PROBE, env_id, str(n), str(steps)], cwd=tree, capture_output=True,
                         text=True, check=True)
    return float(json.loads(res.stdout.strip().splitlines()[-1])["steps_per_s"])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("before", type=Path)
    ap.add_argument("after", type=Path)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--json", type=Path)
    ap.add_argument("--ids", nargs="*", default=list(IDS), help="ids to time (default: all)")
    ap.add_argument("--sizes", nargs="*", type=int, default=[1, 64], help="1: single env; n > 1: vector env")
    args = ap.parse_args(argv)
    rows = []
    print(f"{'id':40s} {'n':>4s} {'before':>10s} {'after':>10s} {'after/before':>12s}")
    for env_id in args.ids:
        for n in args.sizes:
            steps = 2000 if n == 1 else max(20, 12800 // n)
            best = {"before": 0.0, "after": 0.0}
            for _ in range(args.rounds):
                for which in ("before", "after"):
                    best[which] = max(best[which], probe(getattr(args, which).resolve(), env_id, n, steps))
            ratio = best["after"] / best["before"]
            rows.append({"id": env_id, "n": n, **best, "ratio": ratio})
            print(f"{env_id:40s} {n:4d} {best['before']:10.0f} {best['after']:10.0f} {ratio:12.3f}", flush=True)
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
