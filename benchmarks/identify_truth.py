"""Identification on records of an independent truth simulator (``tests.truthsim``), run as a user would.

    python -m benchmarks.identify_truth [--draws 4] [--pairs 8] [--controls 10] [--seed 20250]
                                        [--jobs N] [--only EFFECT] [--out out/identify_truth]
                                        [--quick] [--subprocess] [--redo CASE_SEED ...]
                                        [--rate HZ] [--duration S]
    python -m benchmarks.identify_truth --join DIR [DIR ...] [--exclude CASE_SEED ...] --out DIR

Case set (every case drawn from its own seed, ``seed * 1000 + index``): each single effect of
:data:`tests.truthsim.scenarios.EFFECTS` x ``--draws`` (this holds every member of the look-alike
groups), ``--pairs`` two-effect cases from :data:`PAIRS` (Coulomb + force offset is always a vertical
axis, the offset being gravity), and ``--controls`` nominal records (nothing planted).  Each record
is written to a temporary folder and identified by the CLI exactly as a user would run it::

    vsa_gym.cli.main(["identify", CSV, "--json", JSON])      # --subprocess: python -m vsa_gym.cli identify ...

Scoring of a case: *recovered* when the named set equals the planted set (order-free) and every
planted main parameter is within 15 % of the truth (``|fit - true| / |true|``); *extra* when an
unplanted effect is named; *missed* when a planted one is not; an ``ambiguous`` entry whose
``between`` holds a planted effect counts apart ("ambiguous, truth among them").  Held-out error
improved: ``metrics.after[q].rmse < metrics.before[q].rmse``.  Seconds are normalised to a 20 s
record at 1 kHz (``seconds * 20000 / samples``); that scales the cost of a 200 Hz record (whose stiff modes
ask for more substeps per sample) up five times.  ``--rate 1000 --duration 20`` draws every case at exactly
20 s and 1 kHz instead (the rest of each case as drawn from its seed), so that ``seconds`` itself is the
time per 20 s at 1 kHz; with ``--jobs 1`` and nothing else on the machine, on one core: the linear algebra
library (OpenBLAS) is held to one thread in every worker (``OPENBLAS_NUM_THREADS=1`` and its kin, set before
numpy is imported, unless already set).  That is also faster on a small machine (docs/identification.md, "Time
per record"): its threads spin between the many small least-squares steps, and two runs side by side slow each
other down several times over.

Writes ``OUT/results.json`` (every case and the summary) and ``OUT/results.md``.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path
from typing import Any

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):  # one core, before numpy loads
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

from benchmarks.rule_reach import SPEC_RULES  # noqa: E402
from tests.truthsim.records import read_truth  # noqa: E402
from tests.truthsim.scenarios import EFFECTS, MAIN, draw_case, write_case  # noqa: E402

REL_TOL = 0.15
#: two-effect cases, in the order ``--pairs N`` takes them
PAIRS: tuple[tuple[str, str], ...] = (
    ("coulomb_friction", "force_offset"),  # vertical axis: the offset is gravity
    ("coulomb_friction", "viscous_friction"),
    ("backlash", "coulomb_friction"),
    ("inertia_error", "coulomb_friction"),
    ("gearbox_efficiency", "viscous_friction"),
    ("hysteresis", "coulomb_friction"),  # Dahl presliding beside Coulomb sliding
    ("stribeck_friction", "coulomb_friction"),  # the usual friction curve
    ("transmission_compliance", "sensor_delay"),
)
#: look-alike groups: their members' single-effect cases give the confusion tables
LOOKALIKES: dict[str, tuple[str, ...]] = {
    "transmission": ("backlash", "transmission_compliance", "hysteresis", "coulomb_friction", "gearbox_efficiency"),
    "offset": ("stribeck_friction", "sensor_offset"),
    "constant force": ("coulomb_friction", "force_offset"),
    "speed law": ("coulomb_friction", "viscous_friction"),  # a Coulomb friction with a wide build-up speed v_t
}
QUICK = (("coulomb_friction",), ("backlash",), ("sensor_offset",), ("inertia_error",),
         ("coulomb_friction", "force_offset"), ())


def case_specs(draws: int, pairs: int, controls: int, seed: int, only: str | None = None,
               quick: bool = False, rate: float | None = None, duration: float | None = None) -> list[dict[str, Any]]:
    """The case list: ``{"index", "seed", "effects", "kind", "rate", "duration"}`` (kind: single, pair, control;
    rate and duration: None where drawn)."""
    specs: list[tuple[tuple[str, ...], str]] = []
    if quick:
        specs = [(e, "control" if not e else "single" if len(e) == 1 else "pair") for e in QUICK]
    else:
        for eff in EFFECTS:
            if only is None or eff == only:
                specs += [((eff,), "single")] * draws
        chosen = [PAIRS[i % len(PAIRS)] for i in range(pairs)]
        specs += [(p, "pair") for p in chosen if only is None or only in p]
        specs += [((), "control")] * controls
    return [{"index": i, "seed": seed * 1000 + i, "effects": list(e), "kind": k, "rate": rate, "duration": duration}
            for i, (e, k) in enumerate(specs)]


def _identify(csv: Path, out: Path, use_subprocess: bool) -> tuple[int, str]:
    argv = ["identify", str(csv), "--json", str(out)]
    if use_subprocess:
        p = subprocess.run([sys.executable, "-m", "vsa_gym.cli", *argv], capture_output=True, text=True, check=False)
        return p.returncode, (p.stdout + p.stderr)[-2000:]
    from vsa_gym import cli

    buf = io.StringIO()
    with contextlib.redirect_stdout(buf), contextlib.redirect_stderr(buf):
        rc = cli.main(argv)
    return int(rc), buf.getvalue()[-2000:]


def run_one(spec: dict[str, Any], use_subprocess: bool = False) -> dict[str, Any]:
    """Draw, write and identify one case; returns its scored outcome."""
    effects = tuple(spec["effects"])
    case = draw_case(spec["seed"], effects, rate=spec.get("rate"), duration=spec.get("duration"))
    row: dict[str, Any] = {**spec, "scenario": case.summary(), "samples": case.n, "named": [], "ambiguous": [],
                           "rel_error": {}, "error": None}
    with tempfile.TemporaryDirectory(prefix="truthsim_") as tmp:
        csv = write_case(case, tmp)
        truth = read_truth(csv)
        row["truth"] = truth["main"]
        row["truth_all"] = truth["planted"]
        out = Path(tmp) / "identification.json"
        t0 = time.perf_counter()
        try:
            rc, log = _identify(csv, out, use_subprocess)
        except Exception as exc:  # noqa: BLE001 -- a crash of the identifier is an outcome to report
            rc, log = -1, f"{type(exc).__name__}: {exc}"
        row["seconds"] = time.perf_counter() - t0
        if rc != 0 or not out.exists():
            row["error"] = f"exit {rc}: {log.strip()[-600:]}"
            return score(row, None)
        result = json.loads(out.read_text())
    return score(row, result)


def score(row: dict[str, Any], result: dict[str, Any] | None) -> dict[str, Any]:
    """Fill ``named``, ``fitted``, ``rel_error``, ``recovered``, ``extra``, ``missed``, ``ambiguous_truth``,
    ``improved`` and ``seconds_per_20s_1kHz`` of a case row from the identifier's JSON."""
    planted = set(row["effects"])
    row["seconds_per_20s_1kHz"] = row["seconds"] * 20000.0 / max(row["samples"], 1)
    if result is None:
        row.update(recovered=False, extra=[], missed=sorted(planted), ambiguous_truth=False, improved=None,
                   fitted={})
        return row
    effects = result.get("effects", [])
    row["named"] = [e["name"] for e in effects]
    row["fitted"] = {e["name"]: e.get("parameters", {}) for e in effects}
    for eff in planted & set(row["named"]):
        got = float(row["fitted"][eff].get(MAIN[eff], np.nan))
        want = float(row["truth"][eff])
        row["rel_error"][eff] = abs(got - want) / abs(want) if want else float("inf")
    # the fitted candidates of every round, to read why an effect was (not) named
    row["candidates"] = [{k: c.get(k) for k in ("round", "name", "val_score", "share", "accepted", "reason")}
                         for c in result.get("candidates", []) if c.get("fitted")]
    row["noise_floor_nrmse"] = result.get("noise_floor_nrmse")
    # how the record was replayed (shooting, a refined substep count), to read where a slow case's time went
    row["replay"] = result.get("replay", "")
    row["ambiguous"] = [list(a.get("between", [])) for a in result.get("ambiguous", []) or []]
    row["ambiguous_truth"] = any(planted & set(b) for b in row["ambiguous"])
    row["extra"] = sorted(set(row["named"]) - planted)
    row["missed"] = sorted(planted - set(row["named"]))
    row["recovered"] = (set(row["named"]) == planted
                        and all(row["rel_error"].get(e, np.inf) <= REL_TOL for e in planted))
    metrics = result.get("metrics", {})
    before, after = metrics.get("before", {}), metrics.get("after", {})
    cols = [c for c in before if c in after]
    row["rmse"] = {c: [before[c].get("rmse"), after[c].get("rmse")] for c in cols}
    row["improved"] = (bool(all(after[c]["rmse"] < before[c]["rmse"] for c in cols)) if cols else None)
    return row


def _pct(k: int, n: int) -> str:
    # one decimal: 225/237 is 94.9 %, short of a 95 % target, not "95 %"
    return f"{100.0 * k / n:.1f} % ({k}/{n})" if n else "–"


def summarise(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """Rates per effect, per look-alike group (confusion), per kind, and the overall figures."""
    singles = [r for r in rows if r["kind"] == "single"]
    pairs = [r for r in rows if r["kind"] == "pair"]
    controls = [r for r in rows if r["kind"] == "control"]
    effect_cases = singles + pairs
    per_effect: dict[str, Any] = {}
    for eff in EFFECTS:
        rs = [r for r in singles if r["effects"] == [eff]]
        if not rs:
            continue
        errs = [r["rel_error"][eff] for r in rs if eff in r["rel_error"]]
        wrong: dict[str, int] = {}
        for r in rs:
            if eff not in r["named"]:
                key = "+".join(r["named"]) or ("error" if r["error"] else "none")
                wrong[key] = wrong.get(key, 0) + 1
        per_effect[eff] = {"cases": len(rs), "recovered": sum(r["recovered"] for r in rs),
                           "named": sum(eff in r["named"] for r in rs),
                           "with_extra": sum(bool(r["extra"]) for r in rs),
                           "ambiguous_truth": sum(bool(r["ambiguous_truth"]) for r in rs),
                           "median_rel_error": float(np.median(errs)) if errs else None, "missed_as": wrong}
    confusion: dict[str, Any] = {}
    for group, members in LOOKALIKES.items():
        table: dict[str, dict[str, int]] = {}
        for eff in members:
            rs = [r for r in singles if r["effects"] == [eff]]
            counts = {m: sum(m in r["named"] for r in rs) for m in members}
            counts["other"] = sum(any(n not in members for n in r["named"]) for r in rs)
            counts["none"] = sum(not r["named"] for r in rs)
            counts["cases"] = len(rs)
            table[eff] = counts
        confusion[group] = table
    pair_rows: dict[str, Any] = {}
    for r in pairs:
        key = "+".join(r["effects"])
        p = pair_rows.setdefault(key, {"cases": 0, "recovered": 0, "named": []})
        p["cases"] += 1
        p["recovered"] += int(r["recovered"])
        p["named"].append(r["named"])
    secs = [r["seconds_per_20s_1kHz"] for r in rows]
    improved = [r for r in effect_cases if r["improved"] is not None]
    return {
        "cases": len(rows), "errors": sum(bool(r["error"]) for r in rows),
        "single_recovery": [sum(r["recovered"] for r in singles), len(singles)],
        "pair_recovery": [sum(r["recovered"] for r in pairs), len(pairs)],
        "controls_naming_anything": [sum(bool(r["named"]) for r in controls), len(controls)],
        "controls_named": sorted({n for r in controls for n in r["named"]}),
        "effect_cases_with_extra": [sum(bool(r["extra"]) for r in effect_cases), len(effect_cases)],
        "ambiguous_truth_among": [sum(bool(r["ambiguous_truth"]) for r in effect_cases), len(effect_cases)],
        "heldout_improved": [sum(bool(r["improved"]) for r in improved), len(improved)],
        "seconds_per_20s_1kHz_median": float(np.median(secs)) if secs else None,
        "seconds_per_20s_1kHz_max": float(np.max(secs)) if secs else None,
        "seconds_median": float(np.median([r["seconds"] for r in rows])) if rows else None,
        "per_effect": per_effect, "confusion": confusion, "pairs": pair_rows,
    }


def markdown(summary: dict[str, Any]) -> str:
    s = summary
    lines = ["# Identification on independent truth-simulator records", "",
             f"- single-effect recovery: {_pct(*s['single_recovery'])}",
             f"- two-effect recovery: {_pct(*s['pair_recovery'])}",
             f"- nominal controls naming anything: {_pct(*s['controls_naming_anything'])} "
             f"{', '.join(s['controls_named'])}",
             f"- effect cases adding an unplanted effect: {_pct(*s['effect_cases_with_extra'])}",
             f"- ambiguous, truth among them: {_pct(*s['ambiguous_truth_among'])}",
             f"- held-out error improved: {_pct(*s['heldout_improved'])}",
             f"- identification time per 20 s at 1 kHz: median {s['seconds_per_20s_1kHz_median'] or 0:.1f} s, "
             f"max {s['seconds_per_20s_1kHz_max'] or 0:.1f} s (median per record "
             f"{s.get('seconds_median') or 0:.1f} s); errors: {s['errors']}", "",
             "| planted effect | cases | recovered (within 15 %) | named | median rel. error | with extra | "
             "ambiguous (truth among) | missed as |", "|---|---|---|---|---|---|---|---|"]
    for eff, r in s["per_effect"].items():
        med = "–" if r["median_rel_error"] is None else f"{r['median_rel_error']:.2g}"
        miss = ", ".join(f"{k} x{v}" for k, v in r["missed_as"].items()) or "–"
        lines.append(f"| {eff} | {r['cases']} | {_pct(r['recovered'], r['cases'])} | {r['named']} | {med} | "
                     f"{r['with_extra']} | {r['ambiguous_truth']} | {miss} |")
    for group, table in s["confusion"].items():
        members = list(LOOKALIKES[group])
        lines += ["", f"Look-alike group *{group}* (rows planted alone, columns named; counts of cases):", "",
                  "| planted \\ named | " + " | ".join(members) + " | other | none | cases |",
                  "|---" * (len(members) + 4) + "|"]
        for eff, c in table.items():
            lines.append(f"| {eff} | " + " | ".join(str(c[m]) for m in members) +
                         f" | {c['other']} | {c['none']} | {c['cases']} |")
    if s["pairs"]:
        lines += ["", "| planted pair | cases | recovered | named |", "|---|---|---|---|"]
        for key, p in s["pairs"].items():
            named = "; ".join("+".join(n) or "none" for n in p["named"])
            lines.append(f"| {key} | {p['cases']} | {p['recovered']} | {named} |")
    return "\n".join(lines) + "\n"


def _progress(i: int, n: int, r: dict[str, Any]) -> str:
    planted = "+".join(r["effects"]) or "control"
    err = ", ".join(f"{k} {v:.2f}" for k, v in r["rel_error"].items()) or "–"
    tag = "ok" if r["recovered"] else ("ERROR" if r["error"] else "--")
    return (f"[{i}/{n}] {tag:5s} {planted:42s} | {r['scenario']} | named: {'+'.join(r['named']) or 'none'} | "
            f"rel err: {err} | {r['seconds']:.1f} s")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--draws", type=int, default=4, help="draws per single effect (default 4)")
    ap.add_argument("--pairs", type=int, default=8, help="two-effect cases (default 8, from PAIRS)")
    ap.add_argument("--controls", type=int, default=10, help="nominal controls (default 10)")
    ap.add_argument("--seed", type=int, default=20250, help="base seed (case seeds: seed * 1000 + index)")
    ap.add_argument("--jobs", type=int, default=1, help="worker processes (default 1)")
    ap.add_argument("--only", choices=EFFECTS, default=None, help="single and pair cases of this effect only")
    ap.add_argument("--out", default="out/identify_truth", help="folder for results.json and results.md")
    ap.add_argument("--quick", action="store_true", help="a handful of cases (smoke test)")
    ap.add_argument("--subprocess", action="store_true", help="run `python -m vsa_gym.cli identify` per case")
    ap.add_argument("--rate", type=float, default=None, metavar="HZ",
                    help="draw every case at this sample rate (default: drawn, 200-5000 Hz)")
    ap.add_argument("--duration", type=float, default=None, metavar="S",
                    help="draw every case this long (default: drawn, 5-20 s)")
    ap.add_argument("--redo", type=int, nargs="+", default=None, metavar="CASE_SEED",
                    help="re-run only these case seeds of OUT/results.json (e.g. after a fix of a crash) and "
                         "re-summarise; the other cases are kept as they are")
    ap.add_argument("--kind", choices=("single", "pair", "control"), nargs="+", default=None,
                    help="run only the drawn cases of these kinds (their case seeds as in the whole set)")
    ap.add_argument("--reach", choices=sorted(SPEC_RULES), default=None,
                    help="run only the drawn cases this rule of benchmarks.rule_reach can reach (decided from the "
                         "record alone; the case seeds as in the whole set), e.g. a change's before/after check")
    ap.add_argument("--unreached", choices=sorted(SPEC_RULES), default=None,
                    help="run only the drawn cases this rule cannot reach (the rest of a set run with --reach)")
    ap.add_argument("--join", nargs="+", default=None, metavar="DIR",
                    help="pool the cases of these earlier OUT folders (their results.json) into one summary in "
                         "--out; nothing is re-run")
    ap.add_argument("--exclude", type=int, nargs="+", default=[], metavar="CASE_SEED",
                    help="with --join: leave these case seeds out of the pooled summary (e.g. the cases a change "
                         "was written on)")
    args = ap.parse_args(argv)
    if args.join:
        rows = [r for d in args.join for r in json.loads((Path(d) / "results.json").read_text())["cases"]]
        missing = sorted(set(args.exclude) - {r["seed"] for r in rows})
        if missing:
            raise SystemExit(f"--exclude: case seeds {missing} are not in the joined results")
        rows = [r for r in rows if r["seed"] not in args.exclude]
        summary = summarise(rows)
        summary["joined"] = list(args.join)
        summary["excluded"] = list(args.exclude)
        _write(Path(args.out), summary, rows, f"{len(rows)} cases joined")
        return 0
    specs = case_specs(args.draws, args.pairs, args.controls, args.seed, args.only, args.quick, args.rate,
                       args.duration)
    if args.kind:
        specs = [s for s in specs if s["kind"] in args.kind]
    if args.reach:
        specs = [s for s in specs if SPEC_RULES[args.reach](s)]
    if args.unreached:
        specs = [s for s in specs if not SPEC_RULES[args.unreached](s)]
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    kept: list[dict[str, Any]] = []
    if args.redo:
        old = json.loads((out / "results.json").read_text())["cases"]
        missing = sorted(set(args.redo) - {r["seed"] for r in old})
        if missing:
            raise SystemExit(f"--redo: case seeds {missing} are not in {out / 'results.json'}")
        kept = [r for r in old if r["seed"] not in args.redo]
        specs = [s for s in specs if s["seed"] in args.redo]
    print(f"{len(specs)} cases, {args.jobs} job(s), base seed {args.seed}", flush=True)
    rows: list[dict[str, Any]] = list(kept)
    t0 = time.perf_counter()
    if args.jobs > 1:
        with ProcessPoolExecutor(max_workers=args.jobs) as pool:
            futures = [pool.submit(run_one, s, args.subprocess) for s in specs]
            for fut in as_completed(futures):
                rows.append(fut.result())
                print(_progress(len(rows) - len(kept), len(specs), rows[-1]), flush=True)
    else:
        for s in specs:
            rows.append(run_one(s, args.subprocess))
            print(_progress(len(rows) - len(kept), len(specs), rows[-1]), flush=True)
    rows.sort(key=lambda r: r["index"])
    summary = summarise(rows)
    summary["wall_seconds"] = time.perf_counter() - t0
    summary["redone"] = args.redo or []
    summary["settings"] = vars(args)
    _write(out, summary, rows, f"{summary['wall_seconds']:.0f} s")
    return 0


def _write(out: Path, summary: dict[str, Any], rows: list[dict[str, Any]], note: str) -> None:
    """``OUT/results.json`` (summary and cases) and ``OUT/results.md`` (the tables), also printed."""
    out.mkdir(parents=True, exist_ok=True)
    (out / "results.json").write_text(json.dumps({"summary": summary, "cases": rows}, indent=2, default=float) + "\n")
    md = markdown(summary)
    (out / "results.md").write_text(md)
    print("\n" + md)
    print(f"wrote {out / 'results.json'} and {out / 'results.md'} ({note})")


if __name__ == "__main__":
    sys.exit(main())
