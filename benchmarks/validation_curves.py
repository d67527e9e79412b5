"""The periodic validation of training runs, one line per run: how a setting learned, without the test episodes.

    python -m benchmarks.validation_curves logs/probe/ppo/vsa_gym-ELPAS-ForceTracking-v0_1 [RUN ...] [--last 8]

Reads each run's ``evaluations.npz`` (written by ``agents.train --eval-freq``, as SB3's ``EvalCallback`` writes it:
``timesteps``, ``results`` and ``ep_lengths`` per validation episode) and prints the number of evaluations, the
best mean validation return and its timestep (the checkpoint ``best_model.zip`` holds), the last ``--last`` mean
returns, and at how many evaluations some validation episode was shorter than the run's longest (on the
tracking tasks: ended on a constraint; on the throw also the release, the task's own end).  The returns are those
of the run's own selection (its training reward, failures charged as its ``--eval-kwargs`` said); the best one is
found by the selection's own rule (``agents.sweep.best_step``).

``--failure-rate R`` also rescores the validation as if a failure had been charged ``R`` per skipped step
instead of the run's own rate (its ``--eval-kwargs``, else its training ``env_kwargs``): an episode of ``L``
steps that ended before the time limit ``T`` gains ``(rate - R) (T - L)``; the line then also gives the
checkpoint the selection would have kept under ``R``.  Only for runs whose failure rate is stated (the eLPAS
tasks): elsewhere a short episode need not be a failure (the throw's release).

``--return-scale`` also prints the scale PPO divided every training reward by at the end of the run: the standard
deviation of the discounted return in the run's final ``VecNormalize`` statistics (``ret_rms``, a running
estimate over every step of the run, ``ENV_NAME/vecnormalize.pkl``).  One early failure charged a large lump
stays in that estimate for the rest of the run and shrinks every later reward the learner sees.
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

import vsa_gym  # noqa: F401  (registers the environments gym.spec reads)
from agents.common import read_vecnormalize, run_args, run_env_kwargs
from agents.evaluate import scoring_env_kwargs
from agents.sweep import best_step


def curve(run: str | os.PathLike[str]) -> dict[str, Any]:
    """``{run, timesteps, mean_return, best_return, best_step, evaluations_with_ended, results, lengths}`` of one
    run folder (``results`` and ``lengths``: per evaluation and validation episode; ``lengths`` ``None`` when the
    record has none)."""
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
            "best_step": int(t[k]), "evaluations_with_ended": ended, "results": r, "lengths": lengths}


def run_failure_charge(run: str | os.PathLike[str]) -> tuple[float, int]:
    """The failure rate a run's validation charged and its episodes' time limit ``T``: the validation
    environment's arguments resolved as the selection resolves them (:func:`agents.evaluate.scoring_env_kwargs`
    of the run's ``env_kwargs``, ``eval_reward`` and ``eval_kwargs``); ``ValueError`` when they state no rate."""
    args_f = next(Path(run).glob("*/args.yml"), None)
    if args_f is None:
        raise FileNotFoundError(f"{run} holds no */args.yml (not a run folder of agents.train)")
    params_dir = args_f.parent
    args = run_args(params_dir)
    env_id = str(args["env"])
    kw = scoring_env_kwargs(env_id, run_env_kwargs(params_dir), args.get("eval_reward", "training"),
                            args.get("eval_kwargs"))[0]
    if kw.get("failure_rate") is None:
        raise ValueError(f"{run}: its validation states no failure_rate (neither --eval-kwargs nor env_kwargs give "
                         "a number: the environment's own default charge, if it has one), so its short episodes "
                         "cannot be rescored")
    steps = kw.get("episode_steps") or gym.spec(env_id).max_episode_steps
    return float(kw["failure_rate"]), int(steps)


def rescore(run: str | os.PathLike[str], c: dict[str, Any], rate: float) -> dict[str, Any]:
    """``c`` (from :func:`curve`) with its mean returns rescored at failure ``rate`` (module docstring):
    ``{mean_return, best_return, best_step, rate, own_rate}``."""
    if c["lengths"] is None:
        raise ValueError(f"{run}: its evaluations.npz holds no episode lengths, so nothing can be rescored")
    own, steps = run_failure_charge(run)
    lengths = np.asarray(c["lengths"], dtype=float)
    mean = (c["results"] + (own - rate) * np.where(lengths < steps, steps - lengths, 0.0)).mean(axis=1)
    k = int(np.argmax(mean))  # the first highest, as the selection keeps it
    return {"mean_return": mean.tolist(), "best_return": float(mean[k]), "best_step": int(c["timesteps"][k]),
            "rate": float(rate), "own_rate": own}


def return_scale(run: str | os.PathLike[str]) -> float:
    """The standard deviation of the discounted return in a run's final ``VecNormalize`` statistics (module
    docstring); ``FileNotFoundError`` naming the file when the run kept none (trained without ``normalize``)."""
    f = next(Path(run).glob("*/vecnormalize.pkl"), None)
    if f is None:
        raise FileNotFoundError(f"{run} holds no */vecnormalize.pkl (a run trained without normalize, or not a run "
                                "folder of agents.train)")
    rms = getattr(read_vecnormalize(f), "ret_rms", None)
    if rms is None:
        raise ValueError(f"{f} holds no return statistics (ret_rms)")
    return float(np.sqrt(np.asarray(rms.var, dtype=float)).reshape(-1)[0])


def line(c: dict[str, Any], last: int) -> str:
    points = list(zip(c["timesteps"], c["mean_return"], strict=True))[-last:]
    tail = ", ".join(f"{t // 1000}k: {m:.1f}" for t, m in points)
    ended = "" if c["evaluations_with_ended"] is None else f"; {c['evaluations_with_ended']} with an ended episode"
    out = (f"{c['run']}: {len(c['timesteps'])} evaluations, best {c['best_return']:.1f} at {c['best_step']}"
           f"{ended} | last {last}: {tail}")
    if "rescored" in c:
        rs = c["rescored"]
        out += (f" | failure_rate {rs['own_rate']:g} -> {rs['rate']:g}: best {rs['best_return']:.1f} at "
                f"{rs['best_step']}")
    if "return_scale" in c:
        out += f" | return scale {c['return_scale']:.1f}"
    return out


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m benchmarks.validation_curves", description=__doc__.split("\n")[0])
    ap.add_argument("runs", nargs="+", help="run folders (each holding evaluations.npz)")
    ap.add_argument("--last", type=int, default=8, help="how many of the latest evaluations to list")
    ap.add_argument("--failure-rate", type=float, default=None, metavar="R",
                    help="also rescore the validation with a failure charged R per skipped step (eLPAS runs)")
    ap.add_argument("--return-scale", action="store_true",
                    help="also print the return scale of the run's final VecNormalize statistics")
    a = ap.parse_args(argv)
    if a.last < 1:
        ap.error(f"--last must be >= 1, got {a.last}")
    if a.failure_rate is not None and not (np.isfinite(a.failure_rate) and a.failure_rate >= 0):
        ap.error(f"--failure-rate must be a finite rate >= 0, got {a.failure_rate}")
    for run in a.runs:
        try:
            c = curve(run)
            if a.failure_rate is not None:
                c["rescored"] = rescore(run, c, a.failure_rate)
            if a.return_scale:
                c["return_scale"] = return_scale(run)
            print(line(c, a.last))
        except (FileNotFoundError, ValueError) as e:
            print(f"error: {e}", file=sys.stderr)
            return 2
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
