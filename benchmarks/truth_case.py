"""One case of the independent truth simulator: write it, replay it at given parameters, identify it.

    python -m benchmarks.truth_case CASE_SEED EFFECT[,EFFECT] [--at KEY=VALUE ...] [--identify] [--out DIR]

The case is drawn as :mod:`benchmarks.identify_truth` draws it (``draw_case(CASE_SEED, EFFECTS)``).  The
replay prints the fit-part and validation NRMSE of the nominal model and of the model with the parameters
given by ``--at`` (identification keys, e.g. ``backlash.width=0.0078``, ``stribeck_friction.sticks=1``);
``--identify`` then runs ``vsa-gym identify`` on the record as a user would (its JSON holds the noise floor,
``noise_floor_nrmse``).  This is how the single-case figures in docs/identification.md are made (e.g.
case 11006: the true Stribeck friction creeping and sticking).
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

import vsa_gym.cli
from tests.truthsim.scenarios import draw_case, write_case
from vsa_gym.identify.adapters import make_adapter
from vsa_gym.identify.fitting import part_nrmse
from vsa_gym.identify.record import load_record


def _pair(text: str) -> tuple[str, float]:
    key, _, value = text.partition("=")
    if not key or not value:
        raise argparse.ArgumentTypeError(f"--at wants KEY=VALUE, got {text!r}")
    return key, float(value)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("seed", type=int, help="case seed (e.g. 11006)")
    ap.add_argument("effects", help="planted effects, comma separated (as the case set draws them)")
    ap.add_argument("--at", type=_pair, action="append", default=[], metavar="KEY=VALUE",
                    help="a parameter of the replay (repeatable)")
    ap.add_argument("--identify", action="store_true", help="also run vsa-gym identify on the record")
    ap.add_argument("--out", type=Path, default=None, help="folder for the record (default: a temporary one)")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        folder = args.out or Path(tmp)
        folder.mkdir(parents=True, exist_ok=True)
        case = draw_case(args.seed, tuple(e for e in args.effects.split(",") if e))
        csv = write_case(case, folder)
        print(f"case {args.seed}: {case.summary()}; planted {case.planted}")
        rec = load_record(csv)
        ad, masks = make_adapter(rec), rec.masks()
        for label, theta in (("nominal", {}), ("at " + " ".join(f"{k}={v:g}" for k, v in args.at), dict(args.at))):
            if label != "nominal" and not theta:
                continue
            y = ad.simulate({k: np.array([v]) for k, v in theta.items()}, 1)[:, 0, :]
            print(f"{label}: fit NRMSE {part_nrmse(ad.measured, y, masks['fit']):.3g}, "
                  f"validation NRMSE {part_nrmse(ad.measured, y, masks['validation']):.3g}")
        if args.identify:
            return vsa_gym.cli.main(["identify", str(csv), "--json", str(folder / "identify.json")])
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
