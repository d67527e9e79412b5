"""Replay one episode of a trained agent or a baseline and print its trajectory: how an episode ended, step by step.

Run::

    python -m benchmarks.agent_replay --env vsa_gym/ELPAS-ForceTracking-v0 --seed 2000006 \\
        --model logs/rl_vs_baselines/ppo/vsa_gym-ELPAS-ForceTracking-v0_5/best_model.zip --every 20 --last 12
    python -m benchmarks.agent_replay --env vsa_gym/ELPAS-ForceTracking-v0 --seed 2000006 \\
        --baseline "cascade (paper)" --every 40 --first 20

The episode is the one :mod:`agents.evaluate` scores: ``baselines.metrics.evaluate_policy`` on the seed with its
per-step traces, the agent built by ``agents.evaluate.agent_policy`` (its training environment arguments and
wrappers, its frozen VecNormalize statistics), a baseline with its own arguments
(``benchmarks.rl_vs_baselines.baseline_factories``).  Printed every ``--every`` steps (``--first`` / ``--last``
rows of that listing): the step, every observation channel, the action and the ``margin_*`` entries of ``info``;
then how the episode ended (step, terminated or truncated, the margins and reward terms of the last step).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from typing import Any

import numpy as np

from agents.common import yaml_mapping


def replay(env_id: str, seed: int, policy_factory: Any, env_kwargs: dict[str, Any]) -> dict[str, Any]:
    """One episode (``evaluate_policy`` on one seed with traces): per-step rows of the observation after the step,
    the action and the ``margin_*`` values, how the episode ended, and the scalars of its last step."""
    from baselines.metrics import evaluate_policy

    seen: dict[str, Any] = {}

    def factory(env: Any) -> Any:  # the evaluation's own env: its observation channels
        seen["env"] = env
        return policy_factory(env)

    res = evaluate_policy(env_id, factory, [seed], env_kwargs=env_kwargs or None, return_traces="all")
    tr = {k: np.asarray(v)[0] for k, v in res["traces"].items()}
    n = int(res["steps"])
    margins = sorted(k for k in tr if k.startswith("margin_"))
    rows = np.concatenate([tr["obs"][:n], tr["action"][:n], np.stack([tr[k][:n] for k in margins], axis=1)], axis=1)
    channels = [c.name for c in seen["env"].unwrapped.task.obs_channels]
    actions = [f"a{i}" for i in range(tr["action"].shape[1])]
    violation = bool(res["per_episode"]["violations"][0])
    terminated = bool(tr["terminated"][n - 1])
    return {"columns": ["step", *channels, *actions, *margins], "rows": rows, "terminated": terminated,
            "truncated": not terminated, "violation": violation,
            "last_info": {k: float(v[n - 1]) for k, v in tr.items() if v.ndim == 1 and k != "terminated"}}


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--env", required=True)
    ap.add_argument("--seed", type=int, required=True, help="the episode's reset seed (test episodes: 2000000 + k)")
    who = ap.add_mutually_exclusive_group(required=True)
    who.add_argument("--model", help="an agent's model .zip")
    who.add_argument("--baseline", help="a baseline's name as in the comparison table, e.g. 'cascade (paper)'")
    ap.add_argument("--env-kwargs", type=yaml_mapping, default=None, metavar="YAML")
    ap.add_argument("--every", type=int, default=50, help="print every N-th step")
    ap.add_argument("--first", type=int, default=None, help="print only the first N rows of the listing")
    ap.add_argument("--last", type=int, default=None, help="print only the last N rows of the listing")
    a = ap.parse_args(argv)
    if a.every < 1:
        ap.error(f"--every must be >= 1, got {a.every}")
    if a.model is not None:
        from agents.evaluate import agent_policy

        factory, kw, _ = agent_policy(a.model, a.env, env_kwargs=a.env_kwargs)
    else:
        from benchmarks.rl_vs_baselines import baseline_factories

        known = baseline_factories(a.env)
        if a.baseline not in known:
            ap.error(f"--baseline {a.baseline!r} is not a baseline of {a.env}; known: {sorted(known)}")
        factory, kw = known[a.baseline]
        kw = {**kw, **(a.env_kwargs or {})}
    res = replay(a.env, a.seed, factory, kw)
    rows = res["rows"]
    idx = np.arange(0, len(rows), a.every)
    if len(rows) and idx[-1] != len(rows) - 1:
        idx = np.append(idx, len(rows) - 1)  # always show the last step
    if a.first is not None:
        idx = idx[:a.first]
    if a.last is not None:
        idx = idx[-a.last:]
    print(" ".join(f"{c:>12s}" for c in res["columns"]))
    for i in idx:
        print(f"{i + 1:12d} " + " ".join(f"{v:12.5g}" for v in rows[i]))
    end = ("terminated (a constraint)" if res["violation"] else
           "terminated (the task's own end, e.g. a throw's release)" if res["terminated"] else "truncated (time limit)")
    print(f"episode ended after {len(rows)} steps: {end}")
    print("last step: " + ", ".join(f"{k} = {v:.5g}" for k, v in res["last_info"].items()
                                      if k.startswith(("margin_", "reward_"))))
    return 0


if __name__ == "__main__":
    sys.exit(main())
