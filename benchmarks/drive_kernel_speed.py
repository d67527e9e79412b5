"""Speed of the generic drive's compiled roll-out and of one identification of a truth-simulator record.

    python -m benchmarks.drive_kernel_speed                       (this checkout only)
    python -m benchmarks.drive_kernel_speed --against DIR [--rounds R]
    python -m benchmarks.drive_kernel_speed --against DIR --compile-only

With ``--against DIR`` (another checkout, e.g. ``git worktree add /tmp/before COMMIT``) both run alternately in
fresh single-threaded interpreters and the last column is ``time(DIR) / time(this)`` (> 1: this checkout is
faster; :mod:`benchmarks.checkouts`).  Figures (best of the rounds):

* ``kernel <effect> ns/row-substep``: :func:`vsa_gym.devices.drive.model.simulate` of 6 rows over 6000 samples of
  2 ms at 8 RK4 substeps, per row and substep (4 right-hand sides), for the nominal drive with a 0.19 ms current
  loop and with Coulomb friction, a Stribeck curve, a compliant shaft, a backlash, a mesh loss or a Dahl loop (a
  Dahl row takes the exponential stepper, whose substep costs more);
* ``compile s`` (``--compile``, or alone with ``--compile-only``): the first roll-out in an interpreter whose numba
  cache is a new empty folder, i.e. compiling the roll-out with everything it calls (what a fresh install pays once);
* ``roll-out dahl 5 um ms/row``: the same 6000 samples with a Dahl loop of 5 um presliding travel at the substeps
  the model chooses itself (8 per sample; before the exponential stepper the Dahl decay at 1 m/s set them: 267), per
  row;
* ``identify truth 5040 s`` (``--identify``): ``vsa_gym.identify.pipeline.identify`` of the independent truth
  simulator's case 5040 (a sensor offset on an open-loop linear motor, 500 Hz, 11.8 s; ``tests.truthsim``), and
  ``identify truth 11000 s`` of case 11000 (Coulomb friction on an open-loop ball screw, 200 Hz, 14.3 s: the
  friction's stick travel makes its candidates stiff), and ``identify truth 11011 1k20 s`` of case 11011 drawn at
  1 kHz for 20 s (viscous friction on a linear motor: its hysteresis candidates were the slow ones).
"""

from __future__ import annotations

import os
import tempfile
import time
from pathlib import Path

import numpy as np

EFFECTS: dict[str, dict[str, float]] = {
    "nominal": {},
    "coulomb": {"F_c": 5.0},
    "stribeck": {"F_c": 5.0, "F_s": 2.0, "v_s": 0.02},
    "compliance": {"k_c": 1e5, "c_c": 20.0, "frac_m": 0.3},
    "backlash": {"backlash": 5e-4, "frac_m": 0.3},
    "mesh loss": {"eta": 0.8, "frac_m": 0.3},
    "dahl": {"F_h": 1.0, "sigma_h": 1e4},
}


def _compile_seconds() -> float:
    """Seconds of the first roll-out in a fresh interpreter of this checkout with an empty numba cache."""
    import subprocess
    import sys

    import vsa_gym

    code = ("import time; import numpy as np; from vsa_gym.devices.drive import model as d; "
            "t = time.perf_counter(); d.simulate(d.DriveParams().vector(2), np.zeros(10), 1e-3, n_sub=4); "
            "print(time.perf_counter() - t)")
    root = Path(vsa_gym.__file__).resolve().parents[1]
    with tempfile.TemporaryDirectory() as cache:
        env = {**os.environ, "NUMBA_CACHE_DIR": cache, "PYTHONPATH": str(root)}
        out = subprocess.run([sys.executable, "-c", code], cwd=root, env=env, capture_output=True, text=True,
                             check=True)
    return float(out.stdout.strip().splitlines()[-1])


def measure() -> dict[str, float]:
    """Time this interpreter's checkout (see the module docstring)."""
    import vsa_gym
    from vsa_gym.devices.drive import model as drive

    out: dict[str, float] = {}
    if os.environ.get("DRIVE_SPEED_COMPILE") in ("1", "only"):
        out["compile s"] = _compile_seconds()
        if os.environ["DRIVE_SPEED_COMPILE"] == "only":
            out["_file"] = vsa_gym.__file__  # type: ignore[assignment]
            return out

    base = drive.DriveParams(m=9.4, b=2.5, k_u=3.8, tau_e=1.9e-4, v_eps=3e-4).vector(1)
    n, T, dt, n_sub = 6, 6000, 2e-3, 8
    u = 2.0 * np.sin(np.arange(T) * dt * 2 * np.pi)
    for name, values in EFFECTS.items():
        P = np.repeat(base, n, axis=0)
        for k, v in values.items():
            P[:, drive.PIDX[k]] = v
        drive.simulate(P, u[:10], dt, n_sub=n_sub)  # compile or load the cache
        best = np.inf
        for _ in range(3):
            t0 = time.perf_counter()
            drive.simulate(P, u, dt, n_sub=n_sub)
            best = min(best, time.perf_counter() - t0)
        out[f"kernel {name} ns/row-substep"] = best / (n * T * n_sub) * 1e9
    P = np.repeat(base, n, axis=0)
    P[:, drive.PIDX["F_h"]], P[:, drive.PIDX["sigma_h"]] = 1.0, 1.0 / 5e-6
    drive.simulate(P, u[:10], dt)
    best = np.inf
    for _ in range(3):
        t0 = time.perf_counter()
        drive.simulate(P, u, dt)
        best = min(best, time.perf_counter() - t0)
    out["roll-out dahl 5 um ms/row"] = best / n * 1e3
    if os.environ.get("DRIVE_SPEED_IDENTIFY") == "1":
        from tests.truthsim.scenarios import draw_case, write_case
        from vsa_gym.identify.pipeline import identify

        for seed, effect, at in ((5040, "sensor_offset", {}), (11000, "coulomb_friction", {}),
                                 (11011, "viscous_friction", {"rate": 1000.0, "duration": 20.0})):
            with tempfile.TemporaryDirectory() as tmp:
                csv = write_case(draw_case(seed, (effect,), **at), tmp)
                t0 = time.perf_counter()
                identify(str(csv))
                out[f"identify truth {seed}{' 1k20' if at else ''} s"] = time.perf_counter() - t0
    out["_file"] = vsa_gym.__file__  # type: ignore[assignment]
    return out


def main(argv: list[str] | None = None) -> None:
    # imported here: measure() also runs in checkouts that lack this module
    from benchmarks.checkouts import compare, speed_parser

    ap = speed_parser(__doc__)
    ap.add_argument("--identify", action="store_true", help="also time one identification (minutes)")
    ap.add_argument("--compile", action="store_true", help="also time compiling the roll-out from an empty cache")
    ap.add_argument("--compile-only", action="store_true", help="time only compiling the roll-out")
    args = ap.parse_args(argv)
    if args.identify:
        os.environ["DRIVE_SPEED_IDENTIFY"] = "1"
    if args.compile or args.compile_only:
        os.environ["DRIVE_SPEED_COMPILE"] = "only" if args.compile_only else "1"
    compare(Path(__file__), args.against, args.rounds, "figure", cache_env="DRIVE_SPEED_CACHE")


if __name__ == "__main__":
    main()
