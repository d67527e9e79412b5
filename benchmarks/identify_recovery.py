"""Recovery rate and parameter error per catalogue effect over N seeds, and the false-positive rate
on negative controls (generic drive, ``vsa_gym.devices.drive.synthetic``).

    python benchmarks/identify_recovery.py [--seeds 20] [--out out/identify_recovery]

Writes ``recovery.json`` and ``recovery.md``.  Recovered = exactly the planted effect is accepted;
parameter error = |fitted - true| / |true| of the main parameter (median over recovered seeds).
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from vsa_gym.devices.drive.effects import LIBRARY as DRIVE_LIBRARY
from vsa_gym.devices.drive.synthetic import DRIVE_EFFECTS, make_drive_record
from vsa_gym.identify.library import main_parameters
from vsa_gym.identify.pipeline import Identifier

MAIN = main_parameters(DRIVE_LIBRARY)  # the drive library's main parameter of each effect


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--out", default="out/identify_recovery")
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rows = {}
    t0 = time.perf_counter()
    for effect in (*DRIVE_EFFECTS, None):
        hits, errs, extra, named = 0, [], 0, []
        for seed in range(args.seeds):
            rec, truth = make_drive_record(1000 + seed, effect)
            res = Identifier().fit(rec).result_
            names = [e["name"] for e in res.effects]
            named.append(names)
            if effect is None:
                extra += bool(names)
                continue
            if names == [effect]:
                hits += 1
                k = MAIN[effect]
                want = truth["params"][f"{effect}.{k}"]
                errs.append(abs(res.effects[0]["parameters"][k] - want) / abs(want))
            elif effect in names:
                extra += 1
        key = effect or "none (negative control)"
        rows[key] = {"seeds": args.seeds, "recovery_rate": hits / args.seeds if effect else None,
                     "median_param_error": float(np.median(errs)) if errs else None,
                     "max_param_error": float(np.max(errs)) if errs else None,
                     "false_positive_rate": extra / args.seeds if effect is None else None,
                     "named_with_extra_effect": extra if effect else None, "named": named}
        print(key, {k: v for k, v in rows[key].items() if k != "named"}, f"{time.perf_counter() - t0:.0f} s",
              flush=True)
    (out / "recovery.json").write_text(json.dumps(rows, indent=2) + "\n")
    lines = ["| effect | recovery rate | median param. error | max param. error | false positives |",
             "|---|---|---|---|---|"]
    for k, r in rows.items():
        def f(v, pct=True, sci=False):
            return "–" if v is None else (f"{v:.1e}" if sci else f"{100 * v:.0f} %" if pct else str(v))
        fp = (f(r["false_positive_rate"]) if r["false_positive_rate"] is not None
              else f(r["named_with_extra_effect"], False))
        lines.append(f"| {k} | {f(r['recovery_rate'])} | {f(r['median_param_error'], sci=True)} | "
                     f"{f(r['max_param_error'], sci=True)} | "
                     f"{fp} |")
    (out / "recovery.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
