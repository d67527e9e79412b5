"""Recovery rate and parameter error per catalogue effect of a device generator over N seeds, and the
false-positive rate on negative controls (vsaUT-II: ``synthetic_vsaut2.RANGES``; eLPAS: ``ELPAS_RANGES``).

    python -m benchmarks.identify_recovery_devices --device {vsaut2,elpas} --seeds N [--out DIR] [--jobs J]

Writes ``DIR/recovery_<device>.json`` (one outcome per identification and the summary rows) and
``DIR/recovery_<device>.md`` (the table) after every finished case, seed-major, so an interrupted
run leaves a consistent table over the seeds done (``--resume`` skips the cases already in the JSON).
Runs split over processes (``--start I`` begins at seed index I, each with its own ``--out``) are
joined with ``--merge JSON... --table-only``.  The table counts only seeds complete for every entry.
Per-case logic: :mod:`vsa_gym.identify.recovery` (the tests use the same).
"""

from __future__ import annotations

import argparse
import json
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path
from typing import Any

from vsa_gym.identify.recovery import DEVICES, catalogue, main_key, negative_experiments, run_case, summarise

EFFECT_SEED0 = 1000  # planted-effect records use seeds 1000 + i
NEGATIVE_SEED0 = 2000  # negative controls 2000 + i


def cases(device: str, seeds: int, experiments: list[str] | None,
          start: int = 0) -> list[tuple[str, str, str | None, int]]:
    """All ``(device, experiment, effect, seed)`` cases of seed indices ``start .. seeds - 1``, seed-major."""
    out = []
    for i in range(start, seeds):
        for exp, eff in catalogue(device):
            if experiments is None or exp in experiments:
                out.append((device, exp, eff, EFFECT_SEED0 + i))
        for exp in negative_experiments(device):
            if experiments is None or exp in experiments:
                out.append((device, exp, None, NEGATIVE_SEED0 + i))
    return out


def table(device: str, outcomes: list[dict[str, Any]]) -> tuple[dict[str, Any], str]:
    """Summary rows and their markdown table."""
    groups: dict[tuple[str, str | None], list[dict[str, Any]]] = {}
    order = [(exp, eff) for exp, eff in catalogue(device)] + [(exp, None) for exp in negative_experiments(device)]
    per_index: dict[int, set[tuple[str, str | None]]] = {}
    for o in outcomes:
        per_index.setdefault(o["seed"] % 1000, set()).add((o["experiment"], o["effect"]))
    present = {key for o in outcomes for key in [(o["experiment"], o["effect"])]}
    complete = {i for i, got in per_index.items() if got >= present}
    for o in outcomes:
        if o["seed"] % 1000 in complete:
            groups.setdefault((o["experiment"], o["effect"]), []).append(o)
    rows: dict[str, Any] = {}
    lines = ["| experiment | planted effect (main parameter) | seeds | recovered alone | median rel. error "
             "| max rel. error | named with an extra effect | missed (named instead) | false-positive rate "
             "| median time |",
             "|---|---|---|---|---|---|---|---|---|---|"]

    def pct(v: float | None) -> str:
        return "–" if v is None else f"{100 * v:.0f} %"

    def sci(v: float | None) -> str:
        return "–" if v is None else f"{v:.2g}"

    for exp, eff in order:
        outs = groups.get((exp, eff), [])
        if not outs:
            continue
        r = summarise(outs)
        rows[f"{exp}/{eff or 'none'}"] = r
        t = f"{r['seconds_median']:.0f} s"
        if eff is None:
            fps = ", ".join(r["false_positives"]) or "–"
            lines.append(f"| {exp} | none (negative control) | {r['seeds']} | – | – | – | – | – | "
                         f"{pct(r['false_positive_rate'])} ({fps}) | {t} |")
        else:
            missed = ", ".join(f"{k} x{v}" for k, v in sorted(r["missed_as"].items())) or "–"
            lines.append(f"| {exp} | {eff} ({main_key(device, eff)}) | {r['seeds']} | {pct(r['recovery_rate'])} | "
                         f"{sci(r['median_param_error'])} | {sci(r['max_param_error'])} | {r['extra']} | {missed} "
                         f"| – | {t} |")
    return rows, "\n".join(lines) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--device", choices=DEVICES, required=True)
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--out", default="out/identify_recovery_devices")
    ap.add_argument("--jobs", type=int, default=1, help="identifications in parallel (processes)")
    ap.add_argument("--experiments", nargs="*", default=None, help="only these experiments")
    ap.add_argument("--resume", action="store_true", help="keep the outcomes already in the JSON")
    ap.add_argument("--start", type=int, default=0, help="first seed index")
    ap.add_argument("--merge", nargs="*", default=[], help="outcome JSONs of other runs to join")
    ap.add_argument("--table-only", action="store_true", help="run nothing, only rebuild the table")
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    js, md = out / f"recovery_{args.device}.json", out / f"recovery_{args.device}.md"
    outcomes: list[dict[str, Any]] = []
    if args.resume and js.exists():
        outcomes = json.loads(js.read_text())["outcomes"]
    for other in args.merge:
        outcomes += json.loads(Path(other).read_text())["outcomes"]
    outcomes = list({(o["experiment"], o["effect"], o["seed"]): o for o in outcomes}.values())
    done = {(o["experiment"], o["effect"], o["seed"]) for o in outcomes}
    todo = [] if args.table_only else [c for c in cases(args.device, args.seeds, args.experiments, args.start)
                                       if (c[1], c[2], c[3]) not in done]
    t0 = time.perf_counter()

    def save() -> None:
        rows, text = table(args.device, outcomes)
        js.write_text(json.dumps({"device": args.device, "seeds_asked": args.seeds, "rows": rows,
                                  "outcomes": outcomes}, indent=1) + "\n")
        md.write_text(text)

    with ProcessPoolExecutor(max_workers=args.jobs) as pool:
        futures = {pool.submit(run_case, *c): c for c in todo}
        for fut in as_completed(futures):
            o = fut.result()
            outcomes.append(o)
            save()
            print(f"{time.perf_counter() - t0:7.0f} s  {o['experiment']:>18} {o['effect'] or 'none':>24} "
                  f"seed {o['seed']}: named {o['named']}, rel. error {o['rel_error']}, {o['seconds']:.0f} s",
                  flush=True)
    save()
    print(md.read_text())


if __name__ == "__main__":
    main()
