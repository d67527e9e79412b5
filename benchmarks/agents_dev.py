"""Agents and baselines on a development set: choose between training settings without the table's test episodes.

Run::

    python -m benchmarks.agents_dev --env vsa_gym/ELPAS-ForceTracking-v0 --episodes 32 \\
        --models logs/probe_a/ppo/*/best_model.zip --models logs/probe_b/ppo/*/best_model.zip \\
        --env-kwargs "{force_range: [2800, 3200]}" --json out/dev_ft.json

Every policy runs the same ``--episodes`` episodes on the seeds ``DEV_SEED_BASE + k`` (``agents.common``: never
used by training, by the periodic evaluation that picks ``best_model.zip`` nor by the comparison table's test
episodes), optionally under other environment arguments (``--env-kwargs``: a stress set such as the top of the
reference range, sensor noise, domain randomisation; they apply on top of each agent's training arguments and
each baseline's own).  Each ``--models`` gives one group of models (one group per setting, e.g. the seeds of one
probe); each group gets a row with its mean over the models and every model a row of its own.
Baselines (``benchmarks.rl_vs_baselines.baseline_factories``; the quarter car's skyhook also at ``--skyhook-gains``)
are evaluated too unless ``--no-baselines``.

Per row: the mean return under the environment's default reward, the task's metric, energy, and the episodes
that ended on a constraint (count, which ``k`` and after how many steps).  A setting is judged here, then the
table is remade once (docs/agents.md); the test episodes never choose.  ``--stochastic`` lets the agents sample
their actions with the exploration noise they were trained with (a diagnostic: what training rollouts cost, e.g.
the energy the noise alone spends); the baselines stay as they are.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from agents.common import DEV_SEED_BASE, write_json, yaml_mapping


def _summary(name: str, res: Mapping[str, Any]) -> dict[str, Any]:
    viol, steps = res["per_episode"]["violations"], res["per_episode"]["steps"]
    ended = [k for k, v in enumerate(viol) if v]
    return {"policy": name, "return": float(res["return"]), "metric": res["metric"],
            "metric_value": float(res["metric_value"]), "energy_J": float(res["energy_J"]),
            "ended": ended, "ended_after": [int(steps[k]) for k in ended], "episodes": len(viol)}


def evaluate_models(env_id: str, groups: Sequence[Sequence[str]], episodes: int, seed_base: int,
                    env_kwargs: Mapping[str, Any] | None, episode_steps: int | None = None,
                    deterministic: bool = True) -> list[dict[str, Any]]:
    """One row per model and one per group of models (the group's mean, its models' ended episodes summed)."""
    from agents.evaluate import evaluate_agent

    rows: list[dict[str, Any]] = []
    for g, models in enumerate(groups):
        own = [_summary(str(m), evaluate_agent(m, env_id, episodes, seed_base, episode_steps=episode_steps,
                                               env_kwargs=env_kwargs, deterministic=deterministic))
               for m in models]
        rows.append({"policy": f"group {g + 1} ({len(own)} models: mean)", "group": g + 1, "kind": "group",
                     "return": float(np.mean([r["return"] for r in own])), "metric": own[0]["metric"],
                     "metric_value": float(np.mean([r["metric_value"] for r in own])),
                     "energy_J": float(np.mean([r["energy_J"] for r in own])),
                     "ended": [len(r["ended"]) for r in own], "episodes": episodes})
        rows.extend({**r, "group": g + 1, "kind": "model"} for r in own)
    return rows


def evaluate_baselines(env_id: str, episodes: int, seed_base: int, env_kwargs: Mapping[str, Any] | None,
                       episode_steps: int | None = None, skyhook_gains: Sequence[float] = ()) -> list[dict[str, Any]]:
    """The table's baselines (``benchmarks.rl_vs_baselines.evaluate_baselines``) on these episodes, summarised."""
    from benchmarks.rl_vs_baselines import evaluate_baselines as table_baselines

    base = table_baselines(env_id, episodes, {}, skyhook_gains, seed_base, env_kwargs, episode_steps)
    return [{**_summary(name, rows[0]), "kind": "baseline"} for name, rows in base.items()]


def table(rows: Sequence[Mapping[str, Any]]) -> str:
    lines = ["| policy | return | metric | energy (J) | ended on a constraint |", "|---|---|---|---|---|"]
    for r in rows:
        ended = r["ended"]
        ended_txt = (f"{sum(ended)} (per model {ended})" if r["kind"] == "group"
                     else f"{len(ended)} of {r['episodes']}"
                     + (f" (k = {ended}, after {r['ended_after']} steps)" if ended else ""))
        lines.append(f"| {r['policy']} | {r['return']:.1f} | {r['metric']} {r['metric_value']:.4g} | "
                     f"{r['energy_J']:.1f} | {ended_txt} |")
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--env", required=True)
    ap.add_argument("--models", nargs="+", action="append", default=[], metavar="MODEL",
                    help="model .zip files of one setting; repeat --models for each further setting")
    ap.add_argument("--episodes", type=int, default=32)
    ap.add_argument("--seed-base", type=int, default=DEV_SEED_BASE)
    ap.add_argument("--env-kwargs", type=yaml_mapping, default=None, metavar="YAML")
    ap.add_argument("--episode-steps", type=int, default=None, help="shorter episodes (default: the time limit)")
    ap.add_argument("--no-baselines", action="store_true")
    ap.add_argument("--skyhook-gains", type=float, nargs="*", default=[],
                    help="quarter car: the skyhook also at these damping gains (N s/m)")
    ap.add_argument("--stochastic", action="store_true",
                    help="agents sample their actions with their training noise (a diagnostic)")
    ap.add_argument("--json", default=None, metavar="FILE")
    a = ap.parse_args(argv)
    if a.episodes < 1:
        ap.error(f"--episodes must be >= 1, got {a.episodes}")
    for m in (m for group in a.models for m in group):
        if not Path(m).is_file():
            ap.error(f"--models: {m} is not a file")
    rows = evaluate_models(a.env, a.models, a.episodes, a.seed_base, a.env_kwargs, a.episode_steps,
                           deterministic=not a.stochastic)
    if not a.no_baselines:
        rows += evaluate_baselines(a.env, a.episodes, a.seed_base, a.env_kwargs, a.episode_steps, a.skyhook_gains)
    print(f"{a.env}: {a.episodes} episodes on seeds {a.seed_base} + k, environment arguments on top: "
          f"{a.env_kwargs or {}}" + ("; agents sample their actions (training noise)" if a.stochastic else ""))
    print(table(rows))
    if a.json:
        write_json(Path(a.json), {"env_id": a.env, "episodes": a.episodes, "seed_base": a.seed_base,
                                  "env_kwargs": a.env_kwargs or {}, "stochastic": a.stochastic, "rows": rows})
    return 0


if __name__ == "__main__":
    sys.exit(main())
