"""The Throw task's baselines: (a) the best fixed-stiffness throw, (b) the optimal-control throw (issue 18).

Run from the repository root::

    python -m benchmarks.throw_baselines            # full grid + optimisation (a few minutes on 2 cores)
    python -m benchmarks.throw_baselines --quick    # a coarse grid and 10 iterations (CI-sized)

Writes ``docs/throw_baselines.json`` (unless ``--json`` says otherwise) and prints the table: release speed,
energy drawn against the 5 J budget, release time, and the gain of (b) over (a) -- what varying the stiffness
buys on this actuator.  Both schedules are also scored by ``baselines.metrics.evaluate_policy`` (the protocol
the agents are compared under), which must give the same release speed as the search's own rollouts.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

import numpy as np

from baselines.metrics import evaluate_policy
from baselines.vsaut2_throw import (
    THROW,
    SchedulePolicy,
    ThrowResult,
    fixed_stiffness_search,
    optimal_throw,
    throw_starts,
)


def protocol_return(result: ThrowResult) -> float:
    """The schedule's mean return under ``evaluate_policy`` (one episode; the Throw start is deterministic)."""
    env_kwargs = {"initial_q1_fraction": result.initial_q1_fraction}
    row = evaluate_policy(THROW, lambda env: SchedulePolicy(result.actions, result.segment_steps), seeds=[0],
                          env_kwargs=env_kwargs)
    return float(row["return"])


def run(quick: bool = False) -> dict[str, Any]:
    t0 = time.perf_counter()
    if quick:
        a = fixed_stiffness_search(q1_fractions=(0.3, 0.7), levels=(0.3, 0.5, 0.7), switches=(0, 4, 8))
    else:
        a = fixed_stiffness_search()
    t_a = time.perf_counter() - t0
    b = optimal_throw(a, starts=throw_starts(a, n_stiffness=1 if quick else 3), max_iter=10 if quick else 60)
    t_b = time.perf_counter() - t0 - t_a
    rows = []
    for r, wall in ((a, t_a), (b, t_b)):
        d = r.to_dict()
        d["protocol_return"] = protocol_return(r)
        d["wall_s"] = wall
        rows.append(d)
    gain = b.release_speed / a.release_speed - 1.0
    return {"quick": quick, "fixed_stiffness": rows[0], "optimal_control": rows[1], "gain_of_b_over_a": gain}


def markdown(res: dict[str, Any]) -> str:
    lines = ["| baseline | release speed (rad/s) | energy (J, budget 5) | release time (s) | pivot drift (rad) "
             "| rollouts | wall (s) |", "|---|---|---|---|---|---|---|"]
    for key in ("fixed_stiffness", "optimal_control"):
        r = res[key]
        lines.append(f"| {r['name']} | {r['release_speed']:.3f} | {r['energy_J']:.2f} | {r['release_time_s']:.3f} "
                     f"| {r['pivot_drift']:.3f} | {r['evaluations']} | {r['wall_s']:.0f} |")
    lines.append(f"\nGain of the optimal-control throw over the best fixed-stiffness throw: "
                 f"{100 * res['gain_of_b_over_a']:+.1f} % release speed.")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--json", type=Path, default=Path("docs/throw_baselines.json"))
    a = ap.parse_args(argv)
    res = run(quick=a.quick)
    print(markdown(res))
    for key in ("fixed_stiffness", "optimal_control"):
        r = res[key]
        if not np.isclose(r["protocol_return"], r["release_speed"], rtol=1e-9, atol=1e-12):
            raise SystemExit(f"{key}: evaluate_policy return {r['protocol_return']} differs from the search's "
                             f"release speed {r['release_speed']}")
    a.json.parent.mkdir(parents=True, exist_ok=True)
    a.json.write_text(json.dumps(res, indent=2) + "\n")
    print(f"wrote {a.json}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
