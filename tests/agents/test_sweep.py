"""A two-trial sweep on a local Ray instance: both trials train, save and evaluate, in separate run folders."""

from __future__ import annotations

from pathlib import Path

import ray  # noqa: F401  (the test extra installs it; a missing Ray must fail, not skip)

from agents.sweep import finished_run, make_trials, run_sweep, run_trial
from tests.agents.conftest import tiny

FORCE = "vsa_gym/ELPAS-ForceTracking-v0"


def test_two_trial_sweep_on_local_ray(tmp_path: Path) -> None:

    trials = make_trials([FORCE], ["ppo"], [0, 1], timesteps=256, log_folder=str(tmp_path), params=tiny("ppo"),
                         episodes=2, episode_steps=40, save_freq=0, eval_freq=0, tensorboard=False)
    results = run_sweep(trials, num_cpus=2)
    assert not ray.is_initialized()  # the local instance was shut down
    assert [r["train_info"]["seed"] for r in results] == [0, 1]
    assert [r["worker_niceness"] for r in results] == [0, 0]  # not Ray's default 15
    paths = {r["train_info"]["save_path"] for r in results}
    assert len(paths) == 2  # concurrent trials claimed distinct run directories
    for r in results:
        assert r["train_info"]["status"] == "finished" and r["train_info"]["num_timesteps"] == 256
        assert r["train_info"]["cpu_s"] > 0 and not r["reused"]
        assert Path(r["train_info"]["model"]).exists()
        assert r["metrics"]["episodes"] == 2 and r["metrics"]["steps"] == 40
    # different seeds give different policies
    assert results[0]["metrics"]["return"] != results[1]["metrics"]["return"]
    # a finished run is reused, not retrained
    again = run_trial(trials[0])
    assert again["reused"] and again["train_info"]["save_path"] == results[0]["train_info"]["save_path"]
    assert again["metrics"] == results[0]["metrics"]
    assert finished_run(tmp_path, FORCE, "ppo", 7, 256) is None


def test_select_best_evaluates_best_model_and_reuses_only_matching_runs(tmp_path: Path) -> None:
    import pytest

    base = dict(timesteps=512, log_folder=str(tmp_path), params=tiny("ppo"), episodes=1, episode_steps=40,
                save_freq=0, eval_freq=256, eval_episodes=2, tensorboard=False)
    trial = make_trials([FORCE], ["ppo"], [0], select="best", **base)[0]
    first = run_trial(trial)
    save = Path(first["train_info"]["save_path"])
    assert first["model"] == str(save / "best_model.zip") and not first["reused"]
    assert first["selected_step"] in (256, 512)
    assert first["metrics"]["agent"]["model"] == first["model"]
    assert run_trial(trial)["reused"]
    # other evaluation settings: the run's best_model.zip was chosen by other rules, so it is trained again
    other = make_trials([FORCE], ["ppo"], [0], select="best", **{**base, "eval_episodes": 3})[0]
    assert finished_run(tmp_path, FORCE, "ppo", 0, 512, {"eval_freq": 256, "eval_episodes": 3,
                                                         "eval_reward": "training", "eval_kwargs": {}}) is None
    assert not run_trial(other)["reused"]
    # the final model is still there to select, and a run without periodic evaluation has no best model
    final = run_trial(make_trials([FORCE], ["ppo"], [0], select="final", **base)[0])
    assert final["reused"] and final["model"] == final["train_info"]["model"]
    plain = run_trial(make_trials([FORCE], ["ppo"], [2], select="final", **{**base, "eval_freq": 0})[0])
    with pytest.raises(ValueError, match="eval_freq > 0"):
        run_trial({**plain["trial"], "select": "best", "eval_freq": 0})
