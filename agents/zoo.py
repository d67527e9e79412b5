"""rl-zoo3's ``args.yml`` for our runs, and the upgrade of the ``args.yml`` of runs made before.

rl-zoo3 writes the whole argument namespace of ``rl_zoo3.train`` to ``SAVE_PATH/ENV_NAME/args.yml``, and its tools
read parts of it: ``rl_zoo3.enjoy`` (like ``record_video`` and ``push_to_hub``) reads ``env_kwargs`` (its
``--env-kwargs``; when not null they replace the ``env_kwargs`` of ``config.yml``), ``get_trained_models`` reads
``env``.  :func:`zoo_args` writes every key of that namespace (:data:`ZOO_TRAIN_ARGS`, rl-zoo3 2.9.2) with what
our run used under rl-zoo3's names (``conf_file``: the hyperparameter file, ``hyperparams``: the ``--params``
overrides, ``n_timesteps``: the training budget, ``log_folder``: the ``-f`` that finds the run), rl-zoo3's
defaults for the rest, and our own keys (``eval_reward``, ``eval_kwargs``).  ``env_kwargs`` is null as in an
rl-zoo3 run without ``--env-kwargs`` (ours live in ``config.yml``, as rl-zoo3's ``-params`` overrides do), except
when ``config.yml`` holds them as a Python-expression string, which only our loader evaluates: then the
evaluated dict.  The files are plain YAML mappings (rl-zoo3 reads them with its loader; they need no
``OrderedDict`` tag, and ``yaml.safe_load`` still reads them).

::

    python -m agents.zoo upgrade logs      # add rl-zoo3's keys to the args.yml of older runs under logs/
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import yaml

from agents.common import eval_zoo_expr, read_yaml, run_config

ZOO_TRAIN_ARGS: dict[str, Any] = {
    "algo": "ppo", "conf_file": None, "device": "auto", "env": "CartPole-v1", "env_kwargs": None,
    "eval_env_kwargs": None, "eval_episodes": 5, "eval_freq": 25000, "gym_packages": [], "hyperparams": None,
    "log_folder": "logs", "log_interval": -1, "max_total_trials": None, "n_eval_envs": 1, "n_evaluations": None,
    "n_jobs": 1, "n_startup_trials": 10, "n_timesteps": -1, "n_trials": 500, "no_optim_plots": False,
    "num_threads": -1, "optimization_log_path": None, "optimize_hyperparameters": False, "progress": False,
    "pruner": "median", "sampler": "tpe", "save_freq": -1, "save_replay_buffer": False, "seed": -1, "storage": None,
    "study_name": None, "tensorboard_log": "", "track": False, "trained_agent": "", "trial_id": None,
    "truncate_last_trajectory": True, "uuid": False, "vec_env": "dummy", "verbose": 1, "wandb_entity": None,
    "wandb_group": None, "wandb_project_name": "sb3", "wandb_tags": [],
}
"""The arguments of ``rl_zoo3.train`` (rl-zoo3 2.9.2) with their defaults: the keys of its ``args.yml``."""

GYM_PACKAGES = ["vsa_gym"]
"""What rl-zoo3 must import (``--gym-packages``) to find the ``vsa_gym/...`` ids."""


def zoo_args(values: Mapping[str, Any], config: Mapping[str, Any]) -> dict[str, Any]:
    """The ``args.yml`` of a run: :data:`ZOO_TRAIN_ARGS`, ``gym_packages: [vsa_gym]``, then ``values`` (rl-zoo3's
    names for what it knows, ours for the rest), and ``env_kwargs`` for the run's ``config`` (module docstring)."""
    out: dict[str, Any] = {**ZOO_TRAIN_ARGS, "gym_packages": list(GYM_PACKAGES), **dict(values)}
    kw = config.get("env_kwargs")
    out["env_kwargs"] = dict(eval_zoo_expr(kw)) if isinstance(kw, str) else None
    return dict(sorted(out.items()))


def write_args(path: str | os.PathLike[str], args: Mapping[str, Any]) -> None:
    Path(path).write_text(yaml.dump(dict(args), sort_keys=True))


def upgrade_args(params_dir: str | os.PathLike[str]) -> bool:
    """Rewrite the ``args.yml`` of one of our runs made before :func:`zoo_args` in rl-zoo3's format; ``True`` if
    it was rewritten.  The old ``hyperparams`` entry (the hyperparameter file) becomes ``conf_file``; the
    ``--params`` overrides, not recorded then, are in ``config.yml``.  rl-zoo3's own files (they have
    ``env_kwargs``) and files already upgraded are left alone."""
    params_dir = Path(params_dir)
    f = params_dir / "args.yml"
    old = dict(read_yaml(f) or {}) if f.exists() else {}
    if not old or "env_kwargs" in old or not {"algo", "env"} <= set(old):
        return False
    values = dict(old)
    conf = values.pop("hyperparams", None)
    values["conf_file"] = str(conf) if conf else None
    values["hyperparams"] = None
    values["log_folder"] = str(params_dir.parent.parent.parent)  # LOG of LOG/ALGO/ENV_NAME_ID/ENV_NAME
    write_args(f, zoo_args(values, run_config(params_dir)))
    return True


def upgrade_folder(folder: str | os.PathLike[str]) -> list[Path]:
    """:func:`upgrade_args` on every run under ``folder`` (a log folder or a run directory); the upgraded files."""
    done = []
    for f in sorted(Path(folder).rglob("args.yml")):
        if (f.parent / "config.yml").exists() and upgrade_args(f.parent):
            done.append(f)
    return done


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m agents.zoo", description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    up = sub.add_parser("upgrade", help="add rl-zoo3's keys to the args.yml of runs made before (in place)")
    up.add_argument("folders", nargs="+", help="log folders or run directories")
    a = ap.parse_args(argv)
    n = 0
    for folder in a.folders:
        for f in upgrade_folder(folder):
            print(f"upgraded {f}")
            n += 1
    print(f"{n} args.yml upgraded")
    return 0


if __name__ == "__main__":
    sys.exit(main())
