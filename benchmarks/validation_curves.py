"""The periodic validation of training runs, one line per run: how a setting learned, without the test episodes.

    python -m benchmarks.validation_curves logs/probe/ppo/vsa_gym-ELPAS-ForceTracking-v0_1 [RUN ...] [--last 8]

Reads each run's ``evaluations.npz`` (written by ``agents.train --eval-freq``, as SB3's ``EvalCallback`` writes it:
``timesteps``, ``results`` and ``ep_lengths`` per validation episode) and prints the number of evaluations, the
best mean validation return and its timestep (the checkpoint ``best_model.zip`` holds), the last ``--last`` mean
returns, and at how many evaluations some validation episode was shorter than the run's longest (on the
tracking tasks: ended on a constraint; on the throw also the release, the task's own end).  The returns are those
of the run's own selection (its training reward, failures charged as its ``--eval-kwargs`` said); the best one is
found by the selection's own rule (``agents.sweep.best_step``).
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from agents.sweep import best_step


def curve(run: str | os.PathLike[str]) -> dict[str, Any]:
    """``{run, timesteps, mean_return, best_return, best_step, evaluations_with_ended}`` of one run folder."""
    f = Path(run) / "evaluations.npz"
    if not f.is_file():
        raise FileNotFoundError(f"{f} not found: train with --eval-freq > 0, or name the run's folder")
    with np.load(f) as ev:
        t = np.asarray(ev["timesteps"], dtype=np.int64)
        r = np.asarray(ev["results"], dtype=float).reshape(len(t), -1)
        lengths = np.asarray(ev["ep_lengths"]).reshape(len(t), -1) if "ep_lengths" in ev.files else None
    if t.size == 0:
        raise ValueError(f"{f} holds no evaluation yet")
    mean = r.mean(axis=1)
    k = int(np.flatnonzero(t == best_step(run))[0])  # the checkpoint best_model.zip holds
    ended = None
    if lengths is not None:
        longest = lengths.max()
        ended = int(np.sum(np.any(lengths < longest, axis=1)))
    return {"run": str(run), "timesteps": t.tolist(), "mean_return": mean.tolist(), "best_return": float(mean[k]),
            "best_step": int(t[k]), "evaluations_with_ended": ended}


def line(c: dict[str, Any], last: int) -> str:
    points = list(zip(c["timesteps"], c["mean_return"], strict=True))[-last:]
    tail = ", ".join(f"{t // 1000}k: {m:.1f}" for t, m in points)
    ended = "" if c["evaluations_with_ended"] is None else f"; {c['evaluations_with_ended']} with an ended episode"
    return (f"{c['run']}: {len(c['timesteps'])} evaluations, best {c['best_return']:.1f} at {c['best_step']}"
            f"{ended} | last {last}: {tail}")


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m benchmarks.validation_curves", description=__doc__.split("\n")[0])
    ap.add_argument("runs", nargs="+", help="run folders (each holding evaluations.npz)")
    ap.add_argument("--last", type=int, default=8, help="how many of the latest evaluations to list")
    a = ap.parse_args(argv)
    if a.last < 1:
        ap.error(f"--last must be >= 1, got {a.last}")
    for run in a.runs:
        try:
            print(line(curve(run), a.last))
        except (FileNotFoundError, ValueError) as e:
            print(f"error: {e}", file=sys.stderr)
            return 2
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
