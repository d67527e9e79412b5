"""Scheduled exploration noise: the deviation follows the plan at every rollout, PPO does not move it, a resumed
run continues the plan, and the hyperparameters' ``callback`` entry builds it."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from stable_baselines3 import PPO

from agents.exploration import LogStdSchedule
from agents.train import train
from tests.agents.conftest import tiny

FORCE = "vsa_gym/ELPAS-ForceTracking-v0"


def test_the_plan_values() -> None:
    s = LogStdSchedule(start=-1.0, end=[-2.0, -3.0], fraction=0.5)
    np.testing.assert_allclose(s.value(0, 100), [-1.0, -1.0])
    np.testing.assert_allclose(s.value(25, 100), [-1.5, -2.0])
    np.testing.assert_allclose(s.value(80, 100), [-2.0, -3.0])  # held after the fraction
    with pytest.raises(ValueError, match="fraction"):
        LogStdSchedule(fraction=0.0)
    with pytest.raises(ValueError, match="finite"):
        LogStdSchedule(start=float("nan"))


def test_training_follows_the_plan_and_a_resume_continues_it(tmp_path: Path) -> None:
    spec = [{"agents.exploration.LogStdSchedule": {"start": -0.5, "end": -2.5}}]
    rollout = 2 * 128
    info = train(FORCE, "ppo", 4 * rollout, seed=0, log_folder=tmp_path, save_freq=2 * rollout, eval_freq=0,
                 params=tiny("ppo", callback=spec))
    # the last rollout started at 3 of 4 rollouts, and PPO's updates after it did not move the value
    log_std = PPO.load(info["model"], device="cpu").policy.log_std.detach().numpy()
    np.testing.assert_allclose(log_std, -0.5 - 2.0 * 3 / 4, rtol=0, atol=1e-6)
    # resumed to 8 rollouts (the run's config.yml holds the callback): the plan over the new total
    info = train(FORCE, "ppo", 8 * rollout, seed=0, log_folder=tmp_path, resume=True, save_freq=0, eval_freq=0)
    log_std = PPO.load(info["model"], device="cpu").policy.log_std.detach().numpy()
    np.testing.assert_allclose(log_std, -0.5 - 2.0 * 7 / 8, rtol=0, atol=1e-6)
