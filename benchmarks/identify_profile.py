"""Where the time of one identification goes: a truth-simulator case identified under ``cProfile``.

    python -m benchmarks.identify_profile SEED EFFECTS [--rate HZ] [--duration S]

``SEED`` and ``EFFECTS`` name a case as :mod:`benchmarks.identify_truth` draws it (e.g. ``11052
gearbox_efficiency,viscous_friction --rate 1000 --duration 20``, a case of the 30 s timing set).  Prints the wall
time, the share spent inside the compiled drive kernel (``simulate_kernel``) with its number of calls, and the
cumulative time of the selection's phases (each a method of :class:`vsa_gym.identify.pipeline.Identifier`, read
from the profile by name; phases nest, so their times overlap), and the report's replay line (which says whether the
replay's substeps were refined).  One core: OpenBLAS is held to one thread as in
``identify_truth``.
"""

from __future__ import annotations

import argparse
import cProfile
import os
import pstats
import tempfile
import time

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):  # one core, before numpy loads
    os.environ.setdefault(_var, "1")

from tests.truthsim.scenarios import draw_case, write_case  # noqa: E402
from vsa_gym.identify.pipeline import identify  # noqa: E402

#: the selection's phases reported (method names of ``Identifier``, the replay's convergence check
#: :func:`vsa_gym.identify.convergence.refined` and the kernel)
PHASES = ("_forward", "_with", "_reordered", "_together", "_swap", "_runner_up", "_on_windows", "_second_opinion",
          "refined", "_refit_refined", "simulate_kernel")


def case_parser(description: str) -> argparse.ArgumentParser:
    """A parser of one truth-simulator case as :mod:`benchmarks.identify_truth` draws it: ``seed``, ``effects``
    (comma separated; :func:`planted` splits them), ``--rate`` and ``--duration``."""
    ap = argparse.ArgumentParser(description=description)
    ap.add_argument("seed", type=int, help="case seed (e.g. 11052)")
    ap.add_argument("effects", help="planted effects, comma separated ('' for a nominal control)")
    ap.add_argument("--rate", type=float, default=None, help="sample rate as the case set draws it (Hz)")
    ap.add_argument("--duration", type=float, default=None, help="record length as the case set draws it (s)")
    return ap


def planted(args: argparse.Namespace) -> tuple[str, ...]:
    """The planted effects of a :func:`case_parser` namespace."""
    return tuple(e for e in args.effects.split(",") if e)


def main(argv: list[str] | None = None) -> int:
    args = case_parser(__doc__.splitlines()[0]).parse_args(argv)
    effects = planted(args)
    with tempfile.TemporaryDirectory(prefix="truthsim_") as tmp:
        csv = write_case(draw_case(args.seed, effects, rate=args.rate, duration=args.duration), tmp)
        identify(str(csv), candidates=["coulomb_friction"])  # load the compiled kernels outside the profile
        prof = cProfile.Profile()
        t0 = time.perf_counter()
        prof.enable()
        res = identify(str(csv))
        prof.disable()
        wall = time.perf_counter() - t0
    stats = pstats.Stats(prof).stats  # (file, line, name) -> (calls, primitive calls, tottime, cumtime, callers)
    print(f"case {args.seed} ({', '.join(effects) or 'control'}): named {[e['name'] for e in res.effects]}, "
          f"{wall:.1f} s")
    print(f"  replay: {res.replay_mode}")
    for phase in PHASES:
        rows = [v for (_, _, name), v in stats.items() if name == phase]
        if rows:
            calls, cum = sum(r[1] for r in rows), sum(r[3] for r in rows)
            print(f"  {phase:16s} {calls:6d} calls  {cum:8.1f} s  {100 * cum / wall:5.1f} %")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
