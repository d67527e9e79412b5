"""Which candidates did one rule alone refuse, while they replayed the record near its noise floor?

    python -m benchmarks.truth_refusals OUT_DIR [OUT_DIR ...] --rule "parameter at a bound" [--effect backlash]
        [--within 3] [--beside] [--relief 3]

Reads the ``results.json`` of :mod:`benchmarks.identify_truth` runs and lists every candidate whose only
refusal reason is ``--rule`` (after the "on shooting windows" / "from runner-up" prefixes) and whose validation
error is within ``--within`` times the record's noise floor, with the case's planted and named effects and the
best validation error of the candidates that passed in the same round and replay (and its ratio to the refused
one's).  This is
how to see what relaxing one rule would reach before changing it (the ninth session's look at case 97012: a
backlash refused only for its start at the bound, beside the compliance cases where a backlash is refused the
same way).  ``--beside --relief 3 --within 1e9`` lists what the bound relief beside an accepted effect reaches
(:func:`vsa_gym.identify.rules.bound_relieved`: no floor asked for there), in runs made before it.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from benchmarks.truth_compare import bare, phase


def refused_only_by(case: dict[str, Any], rule: str, within: float, effect: str | None) -> list[dict[str, Any]]:
    """The candidates of ``case`` refused by ``rule`` alone, within ``within`` x the noise floor."""
    floor = case.get("noise_floor_nrmse") or 0.0
    out = []
    for c in case["candidates"]:
        val = c.get("val_score")
        if (bare(c["reason"]) == rule and (effect is None or c["name"] == effect) and val is not None and val == val
                and val <= within * floor):
            out.append(c)
    return out


def best_passer(case: dict[str, Any], cand: dict[str, Any]) -> float:
    """The lowest validation error of the candidates that passed in ``cand``'s round and replay (NaN: none)."""
    vals = [c["val_score"] for c in case["candidates"] if c is not cand and c["round"] == cand["round"]
            and phase(c["reason"]) == phase(cand["reason"]) and bare(c["reason"]).startswith("passes")]
    return min(vals, default=float("nan"))


def model_before(case: dict[str, Any], cand: dict[str, Any]) -> float:
    """The validation error of the model ``cand`` was judged against, where the record holds it: the candidate
    accepted in the round before, in the same replay and branch (NaN: round one, or not found)."""
    vals = [c["val_score"] for c in case["candidates"] if c["round"] == cand["round"] - 1 and c["accepted"]
            and phase(c["reason"]) == phase(cand["reason"])]
    return min(vals, default=float("nan"))


def relieved(case: dict[str, Any], cand: dict[str, Any], relief: float) -> bool:
    """Whether ``cand`` validates at least ``relief`` x better than every candidate that passed in its round and
    replay and than the model before (where the record holds it: :func:`model_before`)."""
    v = relief * cand["val_score"]
    return all(not r <= v for r in (best_passer(case, cand), model_before(case, cand)))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dirs", nargs="+", help="OUT folders of benchmarks.identify_truth")
    ap.add_argument("--rule", required=True, help='the refusal reason, e.g. "parameter at a bound"')
    ap.add_argument("--effect", default=None, help="only candidates of this effect")
    ap.add_argument("--within", type=float, default=3.0, help="validation error within this x the noise floor")
    ap.add_argument("--beside", action="store_true",
                    help="only candidates fitted beside an accepted effect (round two on)")
    ap.add_argument("--relief", type=float, default=None,
                    help="only candidates this x better than every passing candidate of their round and replay "
                         "and than the model before (the bound relief's condition, rules.bound_relieved)")
    args = ap.parse_args(argv)
    n = 0
    for d in args.dirs:
        for case in json.loads((Path(d) / "results.json").read_text())["cases"]:
            for c in refused_only_by(case, args.rule, args.within, args.effect):
                if (args.beside and c["round"] < 2) or (args.relief is not None and not relieved(case, c, args.relief)):
                    continue
                n += 1
                best = best_passer(case, c)
                print(f"{case['seed']:6d} planted {'+'.join(case['effects']) or 'nothing':40s} named "
                      f"{'+'.join(case['named']) or 'nothing':40s} round {c['round']} {c['name']}: validation "
                      f"{c['val_score']:.3g}, noise floor {case['noise_floor_nrmse']:.3g}, best passing "
                      f"{best:.3g} ({best / c['val_score']:.2f}x){'' if case.get('recovered') else '  [case missed]'}")
    print(f"{n} candidates refused by {args.rule!r} alone within {args.within:g}x the noise floor"
          f"{' beside an accepted effect' if args.beside else ''}"
          f"{f', {args.relief:g}x better than every passer and the model before' if args.relief else ''}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
