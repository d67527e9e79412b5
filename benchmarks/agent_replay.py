"""Replay one episode of a trained agent or a baseline and print its trajectory: how an episode ended, step by step.

Run::

    python -m benchmarks.agent_replay --env vsa_gym/ELPAS-ForceTracking-v0 --seed 2000006 \\
        --model logs/rl_vs_baselines/ppo/vsa_gym-ELPAS-ForceTracking-v0_5/best_model.zip --every 20 --last 12
    python -m benchmarks.agent_replay --env vsa_gym/ELPAS-ForceTracking-v0 --seed 2000006 \\
        --baseline "cascade (paper)" --every 40 --first 20

The policy runs as :mod:`agents.evaluate` runs it (the agent's training environment arguments and wrappers, its
frozen VecNormalize statistics; a baseline with its own arguments, ``benchmarks.rl_vs_baselines.baseline_factories``)
on ``gym.make(ENV)`` reset with ``--seed``.  Printed every ``--every`` steps (``--first`` / ``--last`` rows of that
listing): the step, every observation channel, the action and the ``margin_*`` entries of ``info``; then how the
episode ended (step, terminated or truncated, the margins and reward terms of the last step).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numpy as np
import yaml

import vsa_gym  # noqa: F401  (registers the ids)


def replay(env_id: str, seed: int, policy_factory: Any, env_kwargs: dict[str, Any]) -> dict[str, Any]:
    """One episode: per-step observations (after the step), actions and ``margin_*`` values, and the last info."""
    env = gym.make(env_id, **env_kwargs)
    try:
        policy = policy_factory(env)
        obs, _ = env.reset(seed=seed)
        if hasattr(policy, "reset"):
            policy.reset()
        rows: list[np.ndarray] = []
        margins: list[str] = []
        info: dict[str, Any] = {}
        term = trunc = False
        while not (term or trunc):
            a = np.asarray(policy(obs), dtype=np.float32).reshape(env.action_space.shape)
            obs, _, term, trunc, info = env.step(a)
            if not margins:
                margins = sorted(k for k in info if k.startswith("margin_"))
            rows.append(np.concatenate([np.atleast_1d(obs), a, [float(info[k]) for k in margins]]))
        channels = [c.name for c in env.unwrapped.task.obs_channels]
        actions = [f"a{i}" for i in range(int(np.prod(env.action_space.shape)))]
        return {"columns": ["step", *channels, *actions, *margins], "rows": np.array(rows), "terminated": term,
                "truncated": trunc, "last_info": {k: v for k, v in info.items() if np.isscalar(v)}}
    finally:
        env.close()


def agent_factory(model: str, env_id: str) -> tuple[Any, dict[str, Any]]:
    """``(policy_factory, env_kwargs)`` of a trained agent, as :func:`agents.evaluate.evaluate_agent` builds them."""
    from agents.evaluate import (
        load_agent,
        run_vecnormalize,
        scoring_env_kwargs,
        training_env_kwargs,
        training_vec_env_wrapper,
        wrapped_policy,
    )

    policy = load_agent(model, vecnormalize=run_vecnormalize(model, env_id))
    kw = scoring_env_kwargs(env_id, training_env_kwargs(model, env_id))[0]
    kw.pop("max_episode_steps", None)
    return wrapped_policy(policy, training_vec_env_wrapper(model, env_id)), kw


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--env", required=True)
    ap.add_argument("--seed", type=int, required=True, help="the episode's reset seed (test episodes: 2000000 + k)")
    who = ap.add_mutually_exclusive_group(required=True)
    who.add_argument("--model", help="an agent's model .zip")
    who.add_argument("--baseline", help="a baseline's name as in the comparison table, e.g. 'cascade (paper)'")
    ap.add_argument("--env-kwargs", type=yaml.safe_load, default=None, metavar="YAML")
    ap.add_argument("--every", type=int, default=50, help="print every N-th step")
    ap.add_argument("--first", type=int, default=None, help="print only the first N rows of the listing")
    ap.add_argument("--last", type=int, default=None, help="print only the last N rows of the listing")
    a = ap.parse_args(argv)
    if a.every < 1:
        ap.error(f"--every must be >= 1, got {a.every}")
    if a.env_kwargs is not None and not isinstance(a.env_kwargs, dict):
        ap.error(f"--env-kwargs must be a YAML mapping, got {a.env_kwargs!r}")
    if a.model is not None:
        factory, kw = agent_factory(a.model, a.env)
    else:
        from benchmarks.rl_vs_baselines import baseline_factories

        known = baseline_factories(a.env)
        if a.baseline not in known:
            ap.error(f"--baseline {a.baseline!r} is not a baseline of {a.env}; known: {sorted(known)}")
        factory, kw = known[a.baseline]
        kw = dict(kw)
    res = replay(a.env, a.seed, factory, {**kw, **(a.env_kwargs or {})})
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
    end = "terminated (a constraint)" if res["terminated"] else "truncated (time limit)"
    print(f"episode ended after {len(rows)} steps: {end}")
    print("last step: " + ", ".join(f"{k} = {v:.5g}" for k, v in res["last_info"].items()
                                      if k.startswith(("margin_", "reward_"))))
    return 0


if __name__ == "__main__":
    sys.exit(main())
