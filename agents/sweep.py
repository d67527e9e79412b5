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
retrained (``--retrain`` forces training).  ``--select best`` evaluates each run's
``best_model.zip`` (the checkpoint with the best periodic evaluation on the validation seeds, see
:mod:`agents.train`) instead of its final model; a run is then reused only if it was trained with
the same periodic-evaluation settings.  The JSON lists one record per trial: the
``train_info`` (timesteps, CPU and wall seconds, paths) and the ``metrics``.  Residual trials (hyperparameters
with a wrapper of :mod:`agents.residual`) train and are reused under ``LOG_FOLDER/residual``
(:func:`agents.common.run_log_folder`).
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

from agents.common import (
    METRIC_SEED_BASE,
    env_name,
    read_hyperparams,
    read_json,
    run_args,
    run_dirs,
    run_env_kwargs,
    run_log_folder,
    write_json,
    yaml_mapping,
)

REPO_ROOT = Path(__file__).resolve().parents[1]


SELECT = ("final", "best")
"""Which model of a run a trial evaluates: the final one, or ``best_model.zip`` of the periodic evaluation."""


def evaluation_settings(trial: Mapping[str, Any]) -> dict[str, Any]:
    """The periodic-evaluation settings of a trial, as :func:`agents.train.train` writes them to ``args.yml``."""
    return {"eval_freq": int(trial.get("eval_freq", 25_000)), "eval_episodes": int(trial.get("eval_episodes", 4)),
            "eval_reward": trial.get("eval_reward", "training"), "eval_kwargs": dict(trial.get("eval_kwargs") or {})}


def selection_settings(trial: Mapping[str, Any]) -> dict[str, Any] | None:
    """What a reusable run of the trial must share beyond (env, algo, seed, timesteps): the periodic-evaluation
    settings for ``select: best`` (its ``best_model.zip`` must have been chosen by the same rules), else ``None``."""
    select = trial.get("select", "final")
    if select not in SELECT:
        raise ValueError(f"select must be one of {SELECT}, got {select!r}")
    if select == "final":
        return None
    settings = evaluation_settings(trial)
    if settings["eval_freq"] <= 0:
        raise ValueError("select 'best' needs the periodic evaluation: eval_freq > 0")
    return settings


def finished_run(log_folder: str | os.PathLike[str], env_id: str, algo: str, seed: int,
                 timesteps: int | None, evaluation: Mapping[str, Any] | None = None) -> dict[str, Any] | None:
    """``train_info`` of the newest finished run of (env, algo, seed) trained for ``timesteps`` steps, if any.

    ``timesteps`` is compared with the budget the run was given (``target_timesteps``): an on-policy run
    ends on a whole rollout, so its step count can exceed the budget (PPO with 64 rows x 128 steps turns
    1 500 000 into 1 507 328).

    ``evaluation`` (periodic-evaluation settings, :func:`evaluation_settings`): the run must also hold a
    ``best_model.zip`` chosen by the same rules: the same period and number of episodes, and the same
    evaluation environment (its arguments resolved from the run's ``config.yml``, ``eval_reward`` and
    ``eval_kwargs``, so ``eval_reward`` only matters where the run has reward-only arguments).
    """
    from agents.evaluate import scoring_env_kwargs

    for d in reversed(run_dirs(log_folder, algo, env_id)):
        info = read_json(d / "train_info.json")
        if not (info and info.get("status") == "finished" and int(info.get("seed", -1)) == seed
                and (timesteps is None
                     or int(info.get("target_timesteps", info.get("num_timesteps", -1))) == int(timesteps))
                and Path(info["model"]).exists()):
            continue
        if evaluation is not None:
            params_dir = d / env_name(env_id)
            if not ((params_dir / "args.yml").exists() and (params_dir / "config.yml").exists()
                    and (d / "best_model.zip").exists()):
                continue
            args, kw = run_args(params_dir), run_env_kwargs(params_dir)
            had = scoring_env_kwargs(env_id, kw, args.get("eval_reward", "training"), args.get("eval_kwargs"))[0]
            want = scoring_env_kwargs(env_id, kw, evaluation["eval_reward"], evaluation["eval_kwargs"])[0]
            if (args.get("eval_freq"), args.get("eval_episodes"), had) != (
                    evaluation["eval_freq"], evaluation["eval_episodes"], want):
                continue
        return info
    return None


def trial_model(trial: Mapping[str, Any], info: Mapping[str, Any]) -> str:
    """The model a trial evaluates: the run's final model, or its ``best_model.zip`` (``select: best``)."""
    if selection_settings(trial) is None:
        return str(info["model"])
    best = Path(info["save_path"]) / "best_model.zip"
    if not best.exists():
        raise FileNotFoundError(f"{best} does not exist: select 'best' needs a run trained with eval_freq > 0")
    return str(best)


def best_step(save_path: str | os.PathLike[str]) -> int | None:
    """Timestep of the evaluation that ``best_model.zip`` holds (the first highest mean return in
    ``evaluations.npz``, as SB3's ``EvalCallback`` keeps it); ``None`` without periodic evaluations."""
    import numpy as np

    f = Path(save_path) / "evaluations.npz"
    if not f.exists():
        return None
    with np.load(f) as ev:
        if ev["timesteps"].size == 0:
            return None
        return int(ev["timesteps"][int(np.argmax(ev["results"].mean(axis=1)))])


def run_trial(trial: Mapping[str, Any]) -> dict[str, Any]:
    """One sweep trial (runs inside a Ray worker, or directly): train or reuse, then evaluate."""
    from agents.evaluate import evaluate_agent
    from agents.train import train

    t = dict(trial)
    evaluation = selection_settings(t)
    wrapper = read_hyperparams(t["algo"], t["env_id"], t.get("hyperparams"), t.get("params")).get("vec_env_wrapper")
    info = None if t.get("retrain") else finished_run(run_log_folder(t["log_folder"], wrapper), t["env_id"],
                                                      t["algo"], t["seed"], t.get("timesteps"), evaluation)
    reused = info is not None
    if info is None:
        info = train(t["env_id"], t["algo"], t.get("timesteps"), t["seed"], t["log_folder"],
                     hyperparams=t.get("hyperparams"), params=t.get("params") or None,
                     save_freq=t.get("save_freq", 50_000),
                     n_eval_envs=t.get("n_eval_envs"), tensorboard=t.get("tensorboard", True),
                     progress_bar=False, num_threads=1, **evaluation_settings(t))
    finished = info["status"] == "finished"
    model = trial_model(t, info) if finished else None
    out: dict[str, Any] = {"trial": t, "train_info": info, "reused": reused, "model": model,
                           "selected_step": (info["num_timesteps"] if evaluation is None
                                             else best_step(info["save_path"])), "metrics": None,
                           "worker_niceness": os.nice(0) if hasattr(os, "nice") else None}
    if int(t.get("episodes", 0)) > 0 and finished:
        base = int(t.get("seed_base", METRIC_SEED_BASE))
        steps = t.get("episode_steps")
        tag = "" if evaluation is None else "_best"
        cached = Path(info["save_path"]) / f"metrics{tag}_{int(t['episodes'])}ep_{base}_{steps or 'full'}.json"
        metrics = read_json(cached) if reused else None  # a fresh training run is always evaluated
        if metrics is None:
            metrics = evaluate_agent(model, t["env_id"], int(t["episodes"]), base, episode_steps=steps)
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
    ap.add_argument("--eval-freq", type=int, default=25_000, help="periodic evaluation period in timesteps (0: off)")
    ap.add_argument("--eval-episodes", type=int, default=4, help="validation episodes per periodic evaluation")
    ap.add_argument("--eval-kwargs", type=yaml_mapping, default=None, metavar="YAML",
                    help='environment arguments of the periodic evaluation, e.g. "{failure_rate: 2.0}"')
    ap.add_argument("--select", choices=SELECT, default="final",
                    help="evaluate the final model or best_model.zip of the periodic evaluation")
    ap.add_argument("--address", default=None, help="Ray cluster address (default: a local instance)")
    ap.add_argument("--num-cpus", type=int, default=2, help="CPUs of the local Ray instance")
    ap.add_argument("--retrain", action="store_true", help="train even if a finished run exists")
    ap.add_argument("--json", default=None)
    a = ap.parse_args(argv)
    from agents.train import parse_params

    trials = make_trials(a.envs, a.algos, a.seeds, timesteps=a.timesteps, log_folder=str(a.log_folder),
                         params=parse_params(a.params), hyperparams=a.hyperparams, episodes=a.episodes,
                         save_freq=a.save_freq,
                         eval_freq=a.eval_freq, eval_episodes=a.eval_episodes, eval_kwargs=a.eval_kwargs,
                         select=a.select, retrain=a.retrain)
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
