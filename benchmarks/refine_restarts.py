"""What the refinement's refit chooses between, on the refined cases of stored truth-simulator runs.

    python -m benchmarks.refine_restarts OUT_DIR [OUT_DIR ...] [--jobs N]

Where the selected model's replay is not converged, :func:`vsa_gym.identify.convergence.refined` refits it at
finer substeps: from its values, and with each effect restarted from its own starts, keeping the fit with the
lowest fit-part NRMSE.  This reads the ``results.json`` of :mod:`benchmarks.identify_truth` runs, takes the cases
whose replay line says so ("refitted at"), identifies each again as the set drew it, and prints per case the
coarse fit's NRMSE, the refit from the values and each restart (fit NRMSE and seconds), the gain of the values
refit (its NRMSE over the coarse one) and whether a restart won by more than 20 %.  This is how the
twenty-fifth session judged a rule that would skip the restarts where the values refit gains enough
(docs/identification.md).  The fits are the estimator's own record of its refined refit
(``Identifier.refine_fits_``), so the choice is the estimator's, unchanged.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):  # one core a worker, before numpy loads
    os.environ.setdefault(_var, "1")

from tests.truthsim.scenarios import draw_case, write_case  # noqa: E402
from vsa_gym.identify.pipeline import Identifier  # noqa: E402
from vsa_gym.identify.record import load_record  # noqa: E402

#: a restart "wins" where its fit-part NRMSE is below this share of the values refit's
WIN = 0.8


def observe(row: dict[str, Any]) -> dict[str, Any]:
    """The refined refit of one stored case, identified again: the estimator's own record of it
    (:attr:`vsa_gym.identify.pipeline.Identifier.refine_fits_`)."""
    case = draw_case(row["seed"], tuple(row["effects"]), rate=row.get("rate"), duration=row.get("duration"))
    with tempfile.TemporaryDirectory(prefix="truthsim_") as tmp:
        est = Identifier().fit(load_record(write_case(case, tmp)))
    return {"seed": row["seed"], "effects": row["effects"], "fits": est.refine_fits_}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dirs", nargs="+", type=Path, help="OUT folders of benchmarks.identify_truth")
    ap.add_argument("--jobs", type=int, default=1, help="worker processes (default 1)")
    args = ap.parse_args(argv)
    rows = [r for d in args.dirs for r in json.loads((d / "results.json").read_text())["cases"]
            if "refitted at" in (r.get("replay") or "")]
    with ProcessPoolExecutor(max_workers=args.jobs) as pool:
        cases = list(pool.map(observe, rows))
    n, wins = 0, []
    for c in cases:
        if not c["fits"]:
            continue
        values = next(f for f in c["fits"] if f["from"] == "values")
        restarts = [f for f in c["fits"] if f["from"] != "values"]
        coarse = values["coarse"]
        gain = values["fit"] / coarse if coarse > 0 else float("nan")
        won = any(f["fit"] < WIN * values["fit"] for f in restarts)
        n += 1
        wins += [(c["seed"], gain)] if won else []
        print(f"{c['seed']:7d} {'+'.join(c['effects']):42s} coarse {coarse:.3g}  values {values['fit']:.3g} "
              f"({values['seconds']:.1f} s, gain {gain:.2f})  " + "  ".join(
                  f"{f['from']} {f['fit']:.3g} ({f['seconds']:.1f} s)" for f in restarts)
              + ("  RESTART WINS" if won else ""))
    gains = ", ".join(f"{s} {g:.2f}" for s, g in wins)
    print(f"{n} refined refits in {len(rows)} cases; a restart won by more than {1 - WIN:.0%} in {len(wins)}"
          f"{' (values-refit gain: ' + gains + ')' if wins else ''}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
