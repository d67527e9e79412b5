"""Agents trained with other reward weights are evaluated under the environment's default reward."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

from agents.evaluate import PROTECTION_KWARGS, REWARD_KWARGS, evaluate_agent, scoring_env_kwargs, split_reward_kwargs
from agents.train import train
from tests.agents.conftest import tiny
from vsa_gym.envs import ENV_IDS

# a value different from every default, per reward-only argument
OTHER: dict[str, Any] = {"w_force": 3.0, "w_energy": 0.05, "force_scale": 250.0, "failure_penalty": 7.0,
                         "regen": "count", "w_comfort": 3.0, "w_travel": 3.0, "w_tyre": 3.0, "accel_scale": 0.5,
                         "travel_soft": 0.5, "w_position": 3.0, "w_stiffness": 3.0, "position_scale": 0.1,
                         "log_stiffness_scale": 0.5, "failure_rate": 50.0, "episode_steps": 1000, "shaping": 1.0,
                         "shaping_gamma": 0.9, "w_stop": 5.0, "stop_width": 1.5}
QC = "vsa_gym/ELPAS-QuarterCar-v0"
FT = "vsa_gym/ELPAS-ForceTracking-v0"


def _rollout(env_id: str, kwargs: dict[str, Any], steps: int = 40) -> dict[str, Any]:
    env = gym.make_vec(env_id, num_envs=2, **kwargs)
    try:
        obs, _ = env.reset(seed=[5, 6])
        rng = np.random.default_rng(0)
        out: dict[str, list[Any]] = {"obs": [obs], "reward": [], "done": []}
        for _ in range(steps):
            a = rng.uniform(-1.0, 1.0, (2, env.single_action_space.shape[0])).astype(np.float32)
            obs, rew, term, trunc, info = env.step(a)
            out["obs"].append(obs)
            out["reward"].append(rew)
            out["done"].append(np.stack([term, trunc]))
            for k, v in info.items():
                if not k.startswith(("_", "reward", "energy_charged")):
                    out.setdefault(k, []).append(np.asarray(v))
        return {k: np.stack(v) for k, v in out.items()}
    finally:
        env.close()


def test_every_registered_env_has_a_list() -> None:
    assert set(REWARD_KWARGS) == set(ENV_IDS)
    assert set().union(*REWARD_KWARGS.values()) <= set(OTHER)


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_reward_only_arguments_change_the_reward_and_nothing_else(env_id: str) -> None:
    ref = _rollout(env_id, {})
    changed = _rollout(env_id, {k: OTHER[k] for k in REWARD_KWARGS[env_id]})
    assert set(ref) == set(changed)
    for key in ref:
        if key != "reward":
            np.testing.assert_array_equal(changed[key], ref[key], err_msg=f"{env_id}: {key} changed")
    if any(k.startswith("w_") or k == "shaping" for k in REWARD_KWARGS[env_id]):
        assert not np.array_equal(changed["reward"], ref["reward"])  # the arguments are live, not misspelt
    for k in REWARD_KWARGS[env_id]:  # each name is an argument of the environment (a misspelt one raises)
        gym.make_vec(env_id, num_envs=1, **{k: OTHER[k]}).close()


def test_split_keeps_the_physics_arguments() -> None:
    env_kw, reward_kw = split_reward_kwargs(QC, {"control_mode": "current", "w_energy": 0.01, "road_class": "C"})
    assert env_kw == {"control_mode": "current", "road_class": "C"} and reward_kw == {"w_energy": 0.01}
    with pytest.raises(ValueError, match="reward-only"):
        split_reward_kwargs("vsa_gym/Unknown-v0", {"w_energy": 0.01})


def test_drive_protections_are_split_off_and_live() -> None:
    """An agent trained without the eLPAS travel limit is scored with it: the split drops ``soft_limit`` under the
    default reward and keeps it under the training reward; the names are the environment's arguments (what they
    do to the dynamics: tests/envs/test_soft_limit.py)."""
    kw = {"control_mode": "current", "soft_limit": None, "w_stop": 10.0}
    assert scoring_env_kwargs(FT, kw)[0] == {"control_mode": "current"}
    assert scoring_env_kwargs(FT, kw)[1] == {"soft_limit": None, "w_stop": 10.0}
    assert scoring_env_kwargs(FT, kw, "training")[0] == kw
    assert set(PROTECTION_KWARGS) <= set(ENV_IDS)
    for env_id, keys in PROTECTION_KWARGS.items():
        assert not keys & REWARD_KWARGS[env_id]  # listed apart: they do change the dynamics
        env = gym.make(env_id, soft_limit=None, soft_limit_decel=50.0)
        assert env.unwrapped.task.soft_limit is None and env.unwrapped.task.soft_limit_decel == 50.0


def test_agent_trained_with_another_energy_price_is_scored_with_the_default_reward(tmp_path: Path) -> None:
    params = tiny("ppo", env_kwargs={"max_episode_steps": 100, "control_mode": "current", "w_energy": 0.5})
    info = train(QC, "ppo", 256, seed=2, log_folder=tmp_path, params=params, save_freq=0, eval_freq=0)
    assert info["status"] == "finished"
    default = evaluate_agent(info["model"], QC, episodes=2, episode_steps=50)
    trained = evaluate_agent(info["model"], QC, episodes=2, episode_steps=50, reward="training")
    explicit = evaluate_agent(info["model"], QC, episodes=2, episode_steps=50, reward="training",
                              env_kwargs={"w_energy": 1e-3})  # the registered default, given by hand
    assert default["agent"]["training_reward_kwargs"] == {"w_energy": 0.5}
    assert default["agent"]["env_kwargs"] == {"control_mode": "current"}
    for key in ("comfort_aw_rms", "tyre_load_rms", "energy_J", "steps", "violations"):
        assert default[key] == trained[key] == explicit[key]
    assert default["return"] == explicit["return"]
    assert default["energy_J"] > 0 and trained["return"] < default["return"]  # the dearer energy costs more
    with pytest.raises(ValueError, match="reward must be"):
        evaluate_agent(info["model"], QC, episodes=1, episode_steps=5, reward="shaped")
