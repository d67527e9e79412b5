"""Time a benchmark's ``measure()`` in fresh interpreters of this checkout and another, alternately.

A speed benchmark that compares a change with the commit it started from defines ``measure() -> dict[str, float]``
(its figures, plus ``"_file": vsa_gym.__file__``) and calls :func:`compare` with another checkout (``git worktree
add /tmp/before COMMIT``).  Each round runs one fresh interpreter per checkout (the other, this one, the other,
...) so that both see the same machine load; every figure is the best of its rounds.  The other checkout is only
read: its bytecode and numba caches go to a temporary directory (``PYTHONPYCACHEPREFIX``, ``NUMBA_CACHE_DIR``).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def speed_parser(doc: str) -> argparse.ArgumentParser:
    """The command line of a before/after speed benchmark: ``--against DIR`` and ``--rounds R``."""
    ap = argparse.ArgumentParser(description=doc.splitlines()[0])
    ap.add_argument("--against", type=Path, help="the other checkout (timed alternately with this one)")
    ap.add_argument("--rounds", type=int, default=2)
    return ap


def run_in(checkout: Path, cache: Path | None, script: Path) -> dict[str, float]:
    """``script``'s ``measure()`` in a fresh single-threaded interpreter importing ``checkout``'s ``vsa_gym``."""
    env = dict(os.environ, PYTHONPATH=str(checkout), NUMBA_NUM_THREADS="1", OMP_NUM_THREADS="1")
    if cache is not None:
        env.update(PYTHONPYCACHEPREFIX=str(cache / "pyc"), NUMBA_CACHE_DIR=str(cache / "numba"))
    code = ("import importlib.util, json; "  # the script by path: ROOT on sys.path would shadow the other vsa_gym
            f"spec = importlib.util.spec_from_file_location('speed_script', {str(script.resolve())!r}); "
            "mod = importlib.util.module_from_spec(spec); spec.loader.exec_module(mod); "
            "print(json.dumps(mod.measure()))")
    res = subprocess.run([sys.executable, "-c", code], cwd=checkout, env=env, capture_output=True, text=True,
                         check=True)
    got = json.loads(res.stdout.strip().splitlines()[-1])
    if not str(got.pop("_file")).startswith(str(checkout)):
        raise RuntimeError(f"{checkout}: imported another vsa_gym")
    return got


def compare(script: Path, other: Path | None, rounds: int, unit: str, cache_env: str = "SPEED_CACHE") -> None:
    """Print ``script``'s figures for this checkout, or before (``other``) / after (this) with their ratio."""
    if other is None:
        for k, v in run_in(ROOT, None, script).items():
            print(f"{k:28s} {v:12.4g} {unit}")
        return
    other = other.resolve()
    best: dict[str, dict[str, float]] = {"before": {}, "after": {}}
    with tempfile.TemporaryDirectory(prefix="speed_") as tmp:
        cache = Path(os.environ.get(cache_env, tmp))  # set it to keep the other checkout's compiled cache
        for r in range(rounds):
            for tag, where, c in (("before", other, cache), ("after", ROOT, None)):
                got = run_in(where, c, script)
                for k, v in got.items():
                    best[tag][k] = min(best[tag].get(k, np.inf), v)
                print(f"round {r + 1}: {tag} done", file=sys.stderr)
    print(f"{unit:28s} {'before':>12s} {'after':>12s} {'before/after':>13s}")
    for k in best["after"]:
        b, a = best["before"].get(k, np.nan), best["after"][k]
        print(f"{k:28s} {b:12.4g} {a:12.4g} {b / a:13.2f}")
