"""How much of a truth-simulator backlash record the drive model can explain at the true gap width.

    python -m benchmarks.backlash_contact [--seed 11012] [--freqs 30 50 80 120] [--zetas 0.05 0.1 0.2 0.4 0.7]

The record is the truth simulator's single-backlash case ``seed`` (``tests.truthsim``: a sharp,
one-sided gap in series with a lightly damped shaft).  The drive model
(:class:`vsa_gym.devices.drive.adapter.DriveAdapter`) replays it with ``backlash.width`` at the truth's
width and the closed gap's contact mode set by hand: frequency ``f`` on the reduced mass
(``k_contact = (2 pi f)^2 m_r``) and damping ratio ``zeta`` (``c_c = 2 zeta sqrt(k m_r)``).  Printed:
the RMS position error on the fit part of the record for every pair, beside the nominal model's
(no backlash).  If no pair comes near the noise floor, the gap's width is not what the model
misses: the impacts are (docs/identification.md, "What still fails").
"""

from __future__ import annotations

import argparse
import dataclasses
import tempfile

import numpy as np

from tests.truthsim.records import read_truth
from tests.truthsim.scenarios import draw_case, write_case
from vsa_gym.devices.drive.adapter import DriveAdapter
from vsa_gym.identify.record import load_record


def contact_grid(seed: int, freqs: list[float], zetas: list[float]) -> dict[str, object]:
    """RMS fit-part errors of the nominal model and of the true width under each contact ``(zeta, f)``."""
    with tempfile.TemporaryDirectory(prefix="backlash_") as tmp:
        csv = write_case(draw_case(seed, ("backlash",)), tmp)
        width = read_truth(csv)["main"]["backlash"]
        record = load_record(csv)
    ad = DriveAdapter(record)
    mask = record.masks()["fit"]
    base = ad.params
    m_r = base.frac_m * (1.0 - base.frac_m) * base.m

    def rms(theta: dict[str, np.ndarray]) -> float:
        y = ad.simulate(theta, 1)[:, 0, 0]
        return float(np.sqrt(np.mean((y - ad.measured[:, 0])[mask] ** 2)))

    nominal = rms({})
    grid = []
    for zeta in zetas:
        row = []
        for f in freqs:
            k = (2 * np.pi * f) ** 2 * m_r
            ad.params = dataclasses.replace(base, k_contact=k, c_c=2 * zeta * np.sqrt(k * m_r))
            row.append(rms({"backlash.width": np.array([width])}))
        grid.append(row)
    ad.params = base
    return {"seed": seed, "width": width, "nominal_rms": nominal, "freqs": freqs, "zetas": zetas, "rms": grid}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=11012, help="truth case seed of a single-backlash case")
    ap.add_argument("--freqs", type=float, nargs="+", default=[30.0, 50.0, 80.0, 120.0])
    ap.add_argument("--zetas", type=float, nargs="+", default=[0.05, 0.1, 0.2, 0.4, 0.7])
    a = ap.parse_args(argv)
    out = contact_grid(a.seed, a.freqs, a.zetas)
    print(f"seed {out['seed']}: true width {out['width']:.4g}, nominal RMS {out['nominal_rms']:.3g}")
    print("zeta \\ f_contact [Hz]  " + "  ".join(f"{f:>8g}" for f in out["freqs"]))
    for z, row in zip(out["zetas"], out["rms"], strict=True):
        print(f"{z:<22g}" + "  ".join(f"{v:8.3g}" for v in row))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
