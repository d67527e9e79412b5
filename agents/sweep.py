"""Multi-seed, multi-environment, multi-algorithm sweeps through Ray.

::

    python -m agents.sweep --envs vsa_gym/ELPAS-ForceTracking-v0 vsa_gym/ELPAS-QuarterCar-v0 \\
        --algos ppo --seeds 0 1 2 --timesteps 200000 --log-folder logs/sweep --json out/sweep.json
    python -m agents.sweep ... --address ray://head:10001     # on a running Ray cluster

Every (env, algo, seed) is one Ray task (``num_cpus=1``) that runs :func:`agents.train.train`
and, with ``--episodes K``, :func:`agents.evaluate.evaluate_agent` on the held-out metric seeds.
Without ``--address`` a local Ray instance is started with ``--num-cpus`` workers (default 2)
and shut down at the end.  On a cluster the log folder must be on storage all nodes share.
A finished run of the same (env, algo, seed, timesteps) in the log folder is reused, not
retrained (``--retrain`` forces training).  The JSON lists one record per trial: the
``train_info`` (timesteps, CPU and wall seconds, paths) and the ``metrics``.
"""

from __future__ import annotations

import argparse
import itertools
import os
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import yaml

from agents.common import METRIC_SEED_BASE, read_json, run_dirs, write_json

REPO_ROOT = Path(__file__).resolve().parents[1]


def finished_run(log_folder: str | os.PathLike[str], env_id: str, algo: str, seed: int,
                 timesteps: int | None) -> dict[str, Any] | None:
    """``train_info`` of the newest finished run of (env, algo, seed) with ``timesteps`` steps, if any."""
    for d in reversed(run_dirs(log_folder, algo, env_id)):
        info = read_json(d / "train_info.json")
        if (info and info.get("status") == "finished" and int(info.get("seed", -1)) == seed
                and (timesteps is None or int(info.get("num_timesteps", -1)) == int(timesteps))
                and Path(info["model"]).exists()):
            return info
    return None


def run_trial(trial: Mapping[str, Any]) -> dict[str, Any]:
    """One sweep trial (runs inside a Ray worker, or directly): train or reuse, then evaluate."""
    from agents.evaluate import evaluate_agent
    from agents.train import train

    t = dict(trial)
    info = None if t.get("retrain") else finished_run(t["log_folder"], t["env_id"], t["algo"], t["seed"],
                                                      t.get("timesteps"))
    reused = info is not None
    if info is None:
        info = train(t["env_id"], t["algo"], t.get("timesteps"), t["seed"], t["log_folder"],
                     hyperparams=t.get("hyperparams"), params=t.get("params") or None,
                     save_freq=t.get("save_freq", 50_000),
                     eval_freq=t.get("eval_freq", 25_000), eval_episodes=t.get("eval_episodes", 4),
                     n_eval_envs=t.get("n_eval_envs", 4), tensorboard=t.get("tensorboard", True),
                     progress_bar=False, num_threads=1)
    out: dict[str, Any] = {"trial": t, "train_info": info, "reused": reused, "metrics": None,
                           "worker_niceness": os.nice(0) if hasattr(os, "nice") else None}
    if int(t.get("episodes", 0)) > 0 and info["status"] == "finished":
        base = int(t.get("seed_base", METRIC_SEED_BASE))
        steps = t.get("episode_steps")
        cached = Path(info["save_path"]) / f"metrics_{int(t['episodes'])}ep_{base}_{steps or 'full'}.json"
        metrics = read_json(cached) if reused else None  # a fresh training run is always evaluated
        if metrics is None:
            metrics = evaluate_agent(info["model"], t["env_id"], int(t["episodes"]), base, episode_steps=steps)
            write_json(cached, metrics)
        out["metrics"] = metrics
    return out


def make_trials(envs: Sequence[str], algos: Sequence[str], seeds: Sequence[int], **common: Any) -> list[dict[str, Any]]:
    """The grid envs x algos x seeds, each with the ``common`` settings."""
    return [{"env_id": e, "algo": a, "seed": int(s), **common} for e, a, s in itertools.product(envs, algos, seeds)]


def run_sweep(trials: Sequence[Mapping[str, Any]], address: str | None = None, num_cpus: int = 2,
              cpus_per_trial: float = 1.0, worker_niceness: int = 0) -> list[dict[str, Any]]:
    """Run the trials as Ray tasks; results in the order of ``trials``.

    ``address=None`` starts (and afterwards shuts down) a local Ray instance with ``num_cpus``;
    otherwise connects to that cluster (``"auto"``, ``"ray://host:10001"``, ...).  Ray starts its
    workers at niceness 15 by default, which starves training on a shared machine; the local
    instance uses ``worker_niceness`` (0: the same priority as the user's other processes).
    """
    try:
        import ray
    except ImportError as exc:
        raise RuntimeError("agents.sweep needs Ray: pip install -e '.[rl]' (or pip install 'ray[default]')") from exc
    started = False
    runtime_env = {"env_vars": {"PYTHONPATH": os.pathsep.join([str(REPO_ROOT), os.environ.get("PYTHONPATH", "")])}}
    if not ray.is_initialized():
        if address is None:
            os.environ["RAY_worker_niceness"] = str(int(worker_niceness))  # noqa: SIM112 (Ray's exact name)
            ray.init(num_cpus=num_cpus, include_dashboard=False, runtime_env=runtime_env, log_to_driver=True,
                     configure_logging=False)
        else:
            ray.init(address=address, runtime_env=runtime_env)
        started = True
    try:
        task = ray.remote(num_cpus=cpus_per_trial, max_retries=0)(run_trial)
        refs = [task.remote(dict(t)) for t in trials]
        return list(ray.get(refs))
    finally:
        if started:
            ray.shutdown()


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m agents.sweep", description=__doc__.split("\n\n")[0])
    ap.add_argument("--envs", nargs="+", required=True)
    ap.add_argument("--algos", nargs="+", default=["ppo"])
    ap.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2])
    ap.add_argument("--timesteps", type=int, default=None, help="per trial (default: the YAML's n_timesteps)")
    ap.add_argument("--log-folder", "-f", default="logs/sweep")
    ap.add_argument("--params", nargs="*", default=[], help="hyperparameter overrides key:value for every trial")
    ap.add_argument("--hyperparams", default=None, help="rl-zoo3 YAML (default agents/hyperparams/ALGO.yml)")
    ap.add_argument("--episodes", type=int, default=10, help="metric episodes per trial (0: no evaluation)")
    ap.add_argument("--save-freq", type=int, default=50_000)
    ap.add_argument("--eval-freq", type=int, default=25_000)
    ap.add_argument("--address", default=None, help="Ray cluster address (default: a local instance)")
    ap.add_argument("--num-cpus", type=int, default=2, help="CPUs of the local Ray instance")
    ap.add_argument("--retrain", action="store_true", help="train even if a finished run exists")
    ap.add_argument("--json", default=None)
    a = ap.parse_args(argv)
    from agents.train import _parse_params

    trials = make_trials(a.envs, a.algos, a.seeds, timesteps=a.timesteps, log_folder=str(a.log_folder),
                         params=_parse_params(a.params), hyperparams=a.hyperparams, episodes=a.episodes,
                         save_freq=a.save_freq,
                         eval_freq=a.eval_freq, retrain=a.retrain)
    results = run_sweep(trials, a.address, a.num_cpus)
    if a.json:
        write_json(a.json, results)
    for r in results:
        ti = r["train_info"]
        print(yaml.safe_dump({"env": ti["env_id"], "algo": ti["algo"], "seed": ti["seed"], "steps": ti["num_timesteps"],
                              "cpu_min": round(ti["cpu_s"] / 60, 3), "reused": r["reused"],
                              "path": ti["save_path"]}, sort_keys=False, default_flow_style=True).strip())
    return 0


if __name__ == "__main__":
    sys.exit(main())
