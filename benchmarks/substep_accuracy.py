"""How the drive's replay of a truth-simulator record converges with the RK4 substeps per sample.

    python -m benchmarks.substep_accuracy SEED EFFECTS [--rate HZ] [--duration S] [--substeps 1 2 4 ...]

Draws the case as :mod:`benchmarks.identify_truth` does (``EFFECTS`` comma separated, ``''`` for a nominal
control), replays it with the nominal model (every base parameter at its sidecar value, no effect) at each number
of substeps, and prints the NRMSE of the position output over the whole record beside the substeps
the model's own rule (:func:`vsa_gym.devices.drive.model.substeps`) picks.  The converged value is the model's
distance from the record; what lies above it at a given substep count is integration error.  Written for the
twenty-first session's look at the drive lag's share of the substeps (docs/identification.md).
"""

from __future__ import annotations

import tempfile

import numpy as np

from benchmarks.identify_profile import case_parser, planted
from tests.truthsim.scenarios import draw_case, write_case
from vsa_gym.devices.drive.model import fastest_rate
from vsa_gym.identify.adapters import make_adapter
from vsa_gym.identify.record import load_record


def main(argv: list[str] | None = None) -> int:
    ap = case_parser(__doc__.splitlines()[0])
    ap.add_argument("--substeps", type=int, nargs="+", default=[1, 2, 4, 8, 16, 32])
    args = ap.parse_args(argv)
    effects = planted(args)
    with tempfile.TemporaryDirectory(prefix="truthsim_") as tmp:
        case = draw_case(args.seed, effects, rate=args.rate, duration=args.duration)
        ad = make_adapter(load_record(str(write_case(case, tmp))))
    theta = {f"base.{b.name}": np.array([b.absent]) for b in ad.base}
    P = ad.param_matrix(theta, 1)
    print(f"case {args.seed} ({', '.join(effects) or 'control'}): {case.rate:g} Hz; the model's rule: "
          f"{ad.substeps(P)} substeps (fastest mode {float(fastest_rate(P)[0]):.4g} 1/s)")
    y_meas = ad.measured[:, 0]
    for n_sub in args.substeps:
        ad.substeps = lambda _P, n=n_sub: n  # type: ignore[method-assign]  # the adapter is this run's own
        y = ad.simulate(theta, 1)[:, 0, 0]
        with np.errstate(all="ignore"):
            nrmse = float(np.sqrt(np.mean((y - y_meas) ** 2)) / np.std(y_meas))
        print(f"  {n_sub:4d} substeps: NRMSE {nrmse:.6g}" + ("" if np.isfinite(nrmse) else " (diverged)"))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
