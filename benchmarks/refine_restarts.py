"""What the refinement's refit chooses between, on the refined cases of stored truth-simulator runs.

    python -m benchmarks.refine_restarts OUT_DIR [OUT_DIR ...] [--jobs N]

Where the selected model's replay is not converged, :func:`vsa_gym.identify.convergence.refined` refits it at
finer substeps: from its values, and with each effect restarted from its own starts, keeping the fit with the
lowest fit-part NRMSE.  This reads the ``results.json`` of :mod:`benchmarks.identify_truth` runs, takes the cases
whose replay line says so ("refitted at"), identifies each again as the set drew it, and prints per case the
coarse fit's NRMSE, the refit from the values and each restart (fit NRMSE and seconds), the gain of the values
refit (its NRMSE over the coarse one) and whether a restart won by more than 20 %.  This is how the
twenty-fifth session judged a rule that would skip the restarts where the values refit gains enough
(docs/identification.md).  The refit is observed by wrapping the estimator's own refits (``Identifier._refit``
and ``Identifier._with``, the methods the profile in :mod:`benchmarks.identify_profile` reads by name), so the
choice is the estimator's, unchanged.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):  # one core a worker, before numpy loads
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

from tests.truthsim.scenarios import draw_case, write_case  # noqa: E402
from vsa_gym.identify.adapters import Adapter  # noqa: E402
from vsa_gym.identify.pipeline import Identifier  # noqa: E402
from vsa_gym.identify.record import load_record  # noqa: E402
from vsa_gym.identify.result import FittedModel  # noqa: E402

#: a restart "wins" where its fit-part NRMSE is below this share of the values refit's
WIN = 0.8


class _Observed(Identifier):
    """The estimator, with the fits of its refined refit recorded in :attr:`log` (its choices unchanged)."""

    def __init__(self) -> None:
        super().__init__()
        self.log: list[dict[str, Any]] = []
        self._depth = 0  # > 0 inside the refined refit; only its own top-level fits are recorded

    def _observe(self, label: str, fit: Any, *args: Any) -> Any:
        if self._depth != 1:
            return fit(*args)
        self._depth += 1
        t0 = time.perf_counter()
        try:
            out = fit(*args)
        finally:
            self._depth -= 1
        self.log[-1]["fits"].append({"from": label, "fit": out.fit_score, "s": time.perf_counter() - t0})
        return out

    def _refit_refined(self, ad: Adapter, fm: FittedModel, masks: dict[str, np.ndarray]) -> FittedModel:
        self.log.append({"coarse": fm.fit_score, "fits": []})
        self._depth += 1
        try:
            return super()._refit_refined(ad, fm, masks)
        finally:
            self._depth -= 1

    def _refit(self, ad: Adapter, fm: FittedModel, masks: dict[str, np.ndarray]) -> FittedModel:
        return self._observe("values", super()._refit, ad, fm, masks)

    def _with(self, ad: Adapter, current: FittedModel, name: str, masks: dict[str, np.ndarray]) -> FittedModel:
        return self._observe(name, super()._with, ad, current, name, masks)


def observe(row: dict[str, Any]) -> dict[str, Any]:
    """The refined refits of one stored case, identified again."""
    case = draw_case(row["seed"], tuple(row["effects"]), rate=row.get("rate"), duration=row.get("duration"))
    with tempfile.TemporaryDirectory(prefix="truthsim_") as tmp:
        est = _Observed().fit(load_record(write_case(case, tmp)))
    return {"seed": row["seed"], "effects": row["effects"], "refits": est.log}


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
        for r in c["refits"]:
            values = next(f for f in r["fits"] if f["from"] == "values")
            restarts = [f for f in r["fits"] if f["from"] != "values"]
            gain = values["fit"] / r["coarse"] if r["coarse"] > 0 else float("nan")
            won = any(f["fit"] < WIN * values["fit"] for f in restarts)
            n += 1
            wins += [(c["seed"], gain)] if won else []
            print(f"{c['seed']:7d} {'+'.join(c['effects']):42s} coarse {r['coarse']:.3g}  values {values['fit']:.3g} "
                  f"({values['s']:.1f} s, gain {gain:.2f})  " + "  ".join(
                      f"{f['from']} {f['fit']:.3g} ({f['s']:.1f} s)" for f in restarts)
                  + ("  RESTART WINS" if won else ""))
    gains = ", ".join(f"{s} {g:.2f}" for s, g in wins)
    print(f"{n} refined refits in {len(rows)} cases; a restart won by more than {1 - WIN:.0%} in {len(wins)}"
          f"{' (values-refit gain: ' + gains + ')' if wins else ''}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
