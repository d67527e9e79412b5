"""Runs interchange with rl-zoo3 both ways, through rl-zoo3's own entry points (issue 18, item 5).

Ours -> ``rl_zoo3.enjoy`` (final model, ``--load-best``, ``--load-checkpoint``, an interrupted run, a residual
run from another directory in a subprocess); ``rl_zoo3.train`` -> :mod:`agents.evaluate`; the YAML loader; the
packaging of the modules the YAML names; residual runs in their own log folder; ``--json`` next to the model.
"""

from __future__ import annotations

import fnmatch
import importlib.metadata
import json
import os
import pickle
import shutil
import subprocess
import sys
import tomllib
from collections import OrderedDict
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.vec_env import VecNormalize

from agents.common import HYPERPARAMS_DIR, env_name, read_yaml, run_log_folder
from agents.evaluate import evaluate_agent, load_agent
from agents.evaluate import main as evaluate_main
from agents.train import train, with_residual
from agents.zoo import ZOO_TRAIN_ARGS, upgrade_folder

FORCE = "vsa_gym/ELPAS-ForceTracking-v0"
NAME = env_name(FORCE)
REPO = Path(__file__).resolve().parents[2]
EPISODE = 30  # enjoy's 50 steps then end exactly one episode: "Episode Length 30" proves the env_kwargs arrived
ENV_KWARGS = {"control_mode": "current", "max_episode_steps": EPISODE}
TINY = {"n_envs": 2, "n_steps": 64, "batch_size": 64, "n_epochs": 1}


def _train(log: Path, params: dict[str, Any], steps: int = 256, **kw: Any) -> dict[str, Any]:
    kw = {"save_freq": 128, "eval_freq": 128, "eval_episodes": 1, "tensorboard": False, **kw}
    return train(FORCE, "ppo", steps, seed=0, log_folder=log, params=params, **kw)


@pytest.fixture(scope="module")
def ours(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """A tiny run of ``agents.train`` (pure PPO, current mode, 30-step episodes, checkpoints at 128 and 256)."""
    info = _train(tmp_path_factory.mktemp("ours") / "logs", {**TINY, "env_kwargs": dict(ENV_KWARGS)})
    assert info["status"] == "finished"
    return info


@pytest.fixture(scope="module")
def zoo_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The run directory of a tiny ``rl_zoo3.train`` run.  Its hyperparameters are our ppo.yml entry without
    ``env_kwargs``, which come from rl-zoo3's ``--env-kwargs`` instead: they end up in ``args.yml`` only."""
    from rl_zoo3.train import train as zoo_train

    root = tmp_path_factory.mktemp("zoo")
    entry = dict(read_yaml(HYPERPARAMS_DIR / "ppo.yml")[FORCE])
    entry.pop("env_kwargs")
    conf = root / "ppo.yml"
    conf.write_text(yaml.safe_dump({FORCE: {**entry, **TINY}}))
    argv = ["train", "--algo", "ppo", "--env", FORCE, "--gym-packages", "vsa_gym", "-n", "256", "-f", str(root),
            "-conf", str(conf), "--eval-freq", "-1", "--save-freq", "128", "--seed", "0", "--num-threads", "1",
            "--device", "cpu", "--verbose", "0",
            "--env-kwargs", "control_mode:'current'", f"max_episode_steps:{EPISODE}"]
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(sys, "argv", argv)
        zoo_train()
    run = root / "ppo" / f"{NAME}_1"
    assert (run / f"{NAME}.zip").exists()
    return run


class _Enjoy:
    """``rl_zoo3.enjoy.enjoy()`` with patched ``sys.argv``; records the environment rl-zoo3 built."""

    def __init__(self, monkeypatch: pytest.MonkeyPatch) -> None:
        import rl_zoo3.enjoy as zoo_enjoy

        self.mp, self.enjoy = monkeypatch, zoo_enjoy.enjoy
        self.env: Any = None
        self.kwargs: dict[str, Any] = {}
        self.steps = 0
        real = zoo_enjoy.create_test_env

        def recording(*args: Any, **kwargs: Any) -> Any:
            env = real(*args, **kwargs)
            self.env, self.kwargs, self.steps = env, kwargs, 0
            step = env.step

            def counting(actions: Any) -> Any:
                self.steps += 1
                return step(actions)

            env.step = counting
            return env

        monkeypatch.setattr(zoo_enjoy, "create_test_env", recording)

    def __call__(self, folder: Path, *extra: str) -> None:
        self.mp.setattr(sys, "argv", ["enjoy", "--algo", "ppo", "--env", FORCE, "-f", str(folder), "--exp-id", "1",
                                      "--gym-packages", "vsa_gym", "--no-render", "-n", "50", "--num-threads", "1",
                                      "--device", "cpu", *extra])
        self.enjoy()


def _vecnormalize(path: Path) -> VecNormalize:
    with open(path, "rb") as fh:
        return pickle.load(fh)


# ---------------------------------------------------------------------------------------------- YAML
def test_loader_reads_rl_zoo3_ordered_dicts_and_refuses_other_python_tags(tmp_path: Path) -> None:
    f = tmp_path / "config.yml"
    f.write_text(yaml.dump(OrderedDict([("normalize", "dict(norm_obs=True)"), ("env_kwargs", None),
                                        ("inner", OrderedDict([("b", [1, 2]), ("a", {"x": 1.5})]))])))
    with pytest.raises(yaml.constructor.ConstructorError):
        yaml.safe_load(f.read_text())  # why we need the loader; safe_load itself stays unchanged
    got = read_yaml(f)
    assert got == {"normalize": "dict(norm_obs=True)", "env_kwargs": None, "inner": {"b": [1, 2], "a": {"x": 1.5}}}
    assert type(got) is dict and list(got) == ["normalize", "env_kwargs", "inner"] and list(got["inner"]) == ["b", "a"]
    for bad in ("!!python/object/apply:os.system ['echo unsafe']", "!!python/name:os.system", "!!python/tuple [1, 2]",
                "!!python/object/apply:collections.OrderedDict {dictitems: {a: 1}}",
                "!!python/object/apply:collections.OrderedDict [[[a, 1, 2]]]"):
        f.write_text(bad)
        with pytest.raises(yaml.constructor.ConstructorError):
            read_yaml(f)


# ---------------------------------------------------------------------------------------------- ours -> rl-zoo3
def test_rl_zoo3_enjoy_runs_our_run_with_its_env_kwargs_and_statistics(
        ours: dict[str, Any], monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    save = Path(ours["save_path"])
    log = Path(ours["log_folder"])
    assert save == log / "ppo" / f"{NAME}_1"
    args = read_yaml(save / NAME / "args.yml")
    assert set(ZOO_TRAIN_ARGS) <= set(args) and args["env_kwargs"] is None and args["gym_packages"] == ["vsa_gym"]
    assert (args["env"], args["seed"], args["n_timesteps"], args["log_folder"]) == (FORCE, 0, 256, str(log))
    final = _vecnormalize(save / "rl_model_vecnormalize_256_steps.pkl")
    assert final.obs_rms.count > 256  # statistics were learnt: a fresh VecNormalize would not match them
    enjoy = _Enjoy(monkeypatch)
    for extra, model in (((), f"{NAME}.zip"), (("--load-best",), "best_model.zip"),
                         (("--load-checkpoint", "128"), "rl_model_128_steps.zip")):
        enjoy(log, *extra)
        out = capsys.readouterr().out
        assert f"Loading {save / model}" in out
        assert enjoy.kwargs["env_kwargs"] == ENV_KWARGS and enjoy.steps == 50
        assert enjoy.env.get_attr("spec")[0].kwargs["control_mode"] == "current"
        assert "Episode Length 30" in out  # the run's max_episode_steps ended the episode
        vn = enjoy.env
        assert isinstance(vn, VecNormalize) and not vn.training and not vn.norm_reward
        np.testing.assert_array_equal(vn.obs_rms.mean, final.obs_rms.mean)
        np.testing.assert_array_equal(vn.obs_rms.var, final.obs_rms.var)


class _Crash(BaseCallback):
    def _on_step(self) -> bool:
        if self.num_timesteps >= 200:
            raise RuntimeError("crash")
        return True


def test_rl_zoo3_enjoy_reads_an_interrupted_run(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(RuntimeError, match="crash"):
        _train(tmp_path, {**TINY, "env_kwargs": dict(ENV_KWARGS)}, eval_freq=0, callbacks=[_Crash()])
    save = tmp_path / "ppo" / f"{NAME}_1"
    assert not (save / f"{NAME}.zip").exists() and (save / "rl_model_128_steps.zip").exists()
    enjoy = _Enjoy(monkeypatch)
    enjoy(tmp_path, "--load-last-checkpoint")
    assert f"Loading {save / 'rl_model_128_steps.zip'}" in capsys.readouterr().out and enjoy.steps == 50
    np.testing.assert_array_equal(enjoy.env.obs_rms.mean,
                                  _vecnormalize(save / "rl_model_vecnormalize_128_steps.pkl").obs_rms.mean)


def test_residual_runs_have_their_own_folder_and_rl_zoo3_loads_them_from_any_directory(tmp_path: Path) -> None:
    from agents.sweep import run_trial

    log = tmp_path / "logs"
    params = with_residual({**TINY, "env_kwargs": {"max_episode_steps": EPISODE}}, "cascade:0.2")
    pure = _train(log, {**TINY, "env_kwargs": dict(ENV_KWARGS)}, eval_freq=0)
    res = _train(log, params, eval_freq=0)
    assert Path(pure["save_path"]) == log / "ppo" / f"{NAME}_1"
    assert Path(res["save_path"]) == log / "residual" / "ppo" / f"{NAME}_1"
    assert res["log_folder"] == str(log / "residual")
    assert load_agent(res["model"]).model.observation_space.shape == (9,)  # observation + the cascade's action
    assert run_log_folder(log / "residual", params["vec_env_wrapper"]) == log / "residual"  # idempotent
    with pytest.raises(ValueError, match="residual runs only"):
        _train(log / "residual", {**TINY, "env_kwargs": dict(ENV_KWARGS)}, eval_freq=0)
    # the sweep and --resume find it there from the same hyperparameters
    trial = {"env_id": FORCE, "algo": "ppo", "seed": 0, "timesteps": 256, "log_folder": str(log), "params": params,
             "episodes": 0, "eval_freq": 0}
    assert run_trial(trial)["reused"] is True
    more = _train(log, params, steps=384, eval_freq=0, resume=True)
    assert more["save_path"] == res["save_path"] and more["num_timesteps"] == 384

    # rl-zoo3's own entry point, started elsewhere, builds agents.residual.ResidualVecEnv from config.yml
    # (else the 8-dimensional observations would not fit the model)
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    cmd = [sys.executable, "-m", "rl_zoo3.enjoy", "--algo", "ppo", "--env", FORCE, "-f", str(log / "residual"),
           "--exp-id", "1", "--gym-packages", "vsa_gym", "--no-render", "-n", "50", "--num-threads", "1",
           "--device", "cpu"]
    done = subprocess.run(cmd, cwd=elsewhere, env={**os.environ, "PYTHONPATH": str(REPO)}, capture_output=True,
                          text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-3000:]
    assert "Episode Length 30" in done.stdout and f"{NAME}_1" in done.stdout


def test_packaging_ships_agents_and_every_module_the_yaml_names() -> None:
    from setuptools import find_packages

    tool = tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["setuptools"]
    packages = set(find_packages(str(REPO), include=tool["packages"]["find"]["include"]))
    assert "agents" in packages
    named = set()
    for f in sorted(HYPERPARAMS_DIR.glob("*.yml")):
        assert any(fnmatch.fnmatch(f"hyperparams/{f.name}", pat) for pat in tool["package-data"]["agents"]), f
        for hp in read_yaml(f).values():
            for key in ("vec_env_wrapper", "env_wrapper", "callback"):
                items = hp.get(key) or []
                named |= {next(iter(it)) if isinstance(it, dict) else it for it in
                          (items if isinstance(items, list) else [items])}
    assert "agents.residual.ResidualVecEnv" in named and "agents.features.LeakyIntegralVecEnv" in named
    for path in named:
        module = path.rpartition(".")[0]
        assert module.rpartition(".")[0] in packages and (REPO / f"{module.replace('.', '/')}.py").exists(), path
    # the generic top-level name is not taken by another installed distribution
    assert set(importlib.metadata.packages_distributions().get("agents", [])) <= {"vsa-gym", "vsa_gym"}


# ---------------------------------------------------------------------------------------------- rl-zoo3 -> ours
def test_agents_evaluate_loads_an_rl_zoo3_run(zoo_run: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    params = zoo_run / NAME
    with pytest.raises(yaml.constructor.ConstructorError):
        yaml.safe_load((params / "config.yml").read_text())  # the OrderedDict dump
    assert "env_kwargs" not in read_yaml(params / "config.yml")
    assert read_yaml(params / "args.yml")["env_kwargs"] == ENV_KWARGS  # rl-zoo3's --env-kwargs
    model = zoo_run / f"{NAME}.zip"
    res = evaluate_agent(model, FORCE, episodes=2, episode_steps=40)
    agent = res["agent"]
    assert agent["env_kwargs"] == {"control_mode": "current"}  # from args.yml; the episode length is the metric's
    assert agent["algo"] == "ppo" and agent["vecnormalize"] == str(params / "vecnormalize.pkl")
    assert res["steps"] == 40 and all(np.isfinite(res[k]) for k in ("return", "metric_value", "energy_J"))
    assert load_agent(model).vecnormalize.obs_rms.count > 256
    # rl-zoo3's checkpoints have no statistics of their own: the run's, as rl_zoo3.enjoy uses them
    ckpt = zoo_run / "rl_model_128_steps.zip"
    assert not (zoo_run / "rl_model_vecnormalize_128_steps.pkl").exists()
    res_ckpt = evaluate_agent(ckpt, FORCE, episodes=1, episode_steps=20)
    assert res_ckpt["agent"]["vecnormalize"] == str(params / "vecnormalize.pkl")
    bare = tmp_path / "bare"
    shutil.copytree(zoo_run, bare)
    (bare / NAME / "vecnormalize.pkl").unlink()
    with pytest.raises(ValueError, match="vecnormalize"):  # never silently unnormalised
        evaluate_agent(bare / "rl_model_128_steps.zip", FORCE, episodes=1, episode_steps=20)

    cwd = tmp_path / "cwd"
    cwd.mkdir()
    monkeypatch.chdir(cwd)
    assert evaluate_main([str(model), "--env", FORCE, "--episodes", "1", "--episode-steps", "20",
                          "--json", "eval.json"]) == 0
    assert not (cwd / "eval.json").exists()  # a relative --json goes next to the model, not the current directory
    written = json.loads((zoo_run / "eval.json").read_text())
    assert np.isfinite(written["metric_value"]) and written["agent"]["env_kwargs"] == {"control_mode": "current"}
    with pytest.raises(SystemExit):
        evaluate_main(["--help"])
    assert "relative to the model's folder" in " ".join(capsys.readouterr().out.split())


def test_our_args_yml_has_every_key_of_rl_zoo3s(ours: dict[str, Any], zoo_run: Path) -> None:
    theirs = read_yaml(zoo_run / NAME / "args.yml")
    mine = read_yaml(Path(ours["save_path"]) / NAME / "args.yml")
    assert set(theirs) == set(ZOO_TRAIN_ARGS) and set(theirs) <= set(mine)
    assert set(mine) - set(theirs) == {"eval_kwargs", "eval_reward"}


def test_upgrade_gives_older_runs_rl_zoo3s_keys(ours: dict[str, Any], tmp_path: Path) -> None:
    run = tmp_path / "logs" / "ppo" / f"{NAME}_1"
    shutil.copytree(ours["save_path"], run)
    old = {"algo": "ppo", "env": FORCE, "seed": 0, "n_timesteps": 256, "hyperparams": "agents/hyperparams/ppo.yml",
           "save_freq": 128, "eval_freq": 128, "eval_episodes": 1, "eval_reward": "training", "eval_kwargs": {}}
    (run / NAME / "args.yml").write_text(yaml.dump(old))  # what agents.train wrote before
    assert upgrade_folder(tmp_path / "logs") == [run / NAME / "args.yml"]
    new = read_yaml(run / NAME / "args.yml")
    assert set(ZOO_TRAIN_ARGS) <= set(new) and new["env_kwargs"] is None and new["hyperparams"] is None
    assert new["conf_file"] == old["hyperparams"] and new["log_folder"] == str(tmp_path / "logs")
    assert {k: new[k] for k in old if k != "hyperparams"} == {k: v for k, v in old.items() if k != "hyperparams"}
    assert upgrade_folder(tmp_path / "logs") == []  # once only
