"""Transfer of the vsaUT-II baselines (and trained agents) between the nominal and the as-measured model.

Each policy is tuned or trained on one parameter set and scored, by ``baselines.metrics.evaluate_policy`` (agents by
``agents.evaluate.evaluate_agent``, the same metrics), on the same held-out seeds of both sets
(``gym.make(id, params="nominal" | "as_measured")``, :meth:`vsa_gym.devices.vsaut2.params.VsaUT2Params.as_measured`)::

    python -m benchmarks.vsaut2_transfer [--episodes 8] [--agent PATH=SET ...] [--json FILE]

``--agent PATH=SET`` adds a trained PositionStiffness agent (its ``.zip``; ``SET`` is the set it was trained on).
The throw rows replay the open-loop schedules of ``docs/throw_baselines.json`` (searched on the nominal model), and
baseline (a) searched again on the as-measured model (``--no-retune`` skips it).
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from agents.common import METRIC_SEED_BASE
from baselines.metrics import evaluate_policy, zero_policy_factory
from baselines.vsaut2_decoupled import vsaut2_decoupled_factory
from baselines.vsaut2_throw import SCHEDULE_LABELS, schedule_factory

PS, THROW = "vsa_gym/VsaUT2-PositionStiffness-v0", "vsa_gym/VsaUT2-Throw-v0"
SETS = ("nominal", "as_measured")
THROW_FILE = Path(__file__).resolve().parents[1] / "docs" / "throw_baselines.json"


def policies(retune: bool = True) -> list[tuple[str, str, str, Callable[[Any], Any], dict[str, Any]]]:
    """``(env_id, name, tuned_on, factory, env_kwargs)`` of every baseline; ``retune`` adds the throw's baseline (a)
    searched again on the as-measured model (``fixed_stiffness_search``, about half a minute)."""
    out: list[tuple[str, str, str, Callable[[Any], Any], dict[str, Any]]] = [
        (PS, "decoupled PID + feed-forward", "nominal", vsaut2_decoupled_factory(), {}),
        (PS, "zero action", "-", zero_policy_factory, {}),
    ]
    throw = json.loads(THROW_FILE.read_text())
    for key, label in SCHEDULE_LABELS.items():
        out.append((THROW, f"throw {label}", "nominal", *schedule_factory(throw[key])))
    if retune:
        from baselines.vsaut2_throw import fixed_stiffness_search

        r = fixed_stiffness_search(env_kwargs={"params": "as_measured"}).to_dict()
        out.append((THROW, "throw (a) fixed stiffness, bang-bang, searched again", "as_measured",
                    *schedule_factory(r)))
    return out


def _summary(env_id: str, row: dict[str, Any]) -> dict[str, float]:
    keys = ("position_rms_rad", "log_stiffness_rms", "energy_J", "return", "violations") if env_id == PS else \
        ("return", "energy_J", "violations")
    return {k: float(row[k]) for k in keys}


def run(episodes: int, agents: Sequence[tuple[str, str]] = (), retune: bool = True) -> list[dict[str, Any]]:
    """One result row per policy: ``{"env", "policy", "tuned_on", "nominal": {...}, "as_measured": {...}}``."""
    seeds = [METRIC_SEED_BASE + k for k in range(episodes)]
    rows: list[dict[str, Any]] = []
    for env_id, name, tuned_on, factory, kw in policies(retune):
        s = seeds if env_id == PS else seeds[:1]  # the throw schedules are open loop: one seed tells all
        rows.append({"env": env_id, "policy": name, "tuned_on": tuned_on, **{
            ps: _summary(env_id, evaluate_policy(env_id, factory, s, env_kwargs={**kw, "params": ps})) for ps in SETS}})
    for path, trained_on in agents:
        from agents.evaluate import evaluate_agent

        rows.append({"env": PS, "policy": f"residual PPO over decoupled ({Path(path).parent.name})",
                     "tuned_on": trained_on, **{
                         ps: _summary(PS, evaluate_agent(path, PS, episodes=episodes, env_kwargs={"params": ps}))
                         for ps in SETS}})
    return rows


def table(rows: list[dict[str, Any]]) -> str:
    """Markdown: per policy, its metrics on each set and the change nominal -> as-measured."""
    out = ["| env | policy | tuned / trained on | metric | nominal | as-measured | change |",
           "|---|---|---|---|---|---|---|"]
    for r in rows:
        first = True
        for k in r["nominal"]:
            a, b = r["nominal"][k], r["as_measured"][k]
            ch = f"{100 * (b - a) / abs(a):+.1f} %" if abs(a) > 1e-9 and k != "violations" else f"{b - a:+.3g}"
            head = f"| {r['env'].split('/')[-1]} | {r['policy']} | {r['tuned_on']} |" if first else "| | | |"
            out.append(f"{head} {k} | {a:.4g} | {b:.4g} | {ch} |")
            first = False
    return "\n".join(out)


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--episodes", type=int, default=8)
    ap.add_argument("--agent", nargs="*", default=[], metavar="PATH=SET",
                    help="trained PositionStiffness agents and the set each was trained on")
    ap.add_argument("--no-retune", action="store_true", help="skip searching the throw baseline (a) again")
    ap.add_argument("--json", default=None)
    a = ap.parse_args(argv)
    agents = []
    for item in a.agent:
        path, _, trained_on = item.rpartition("=")
        if trained_on not in SETS or not path:
            raise SystemExit(f"--agent wants PATH=SET with SET in {SETS}, got {item!r}")
        agents.append((path, trained_on))
    rows = run(a.episodes, agents, retune=not a.no_retune)
    print(table(rows))
    if a.json:
        Path(a.json).write_text(json.dumps(rows, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
