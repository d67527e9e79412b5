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
