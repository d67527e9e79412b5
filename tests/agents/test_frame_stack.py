"""rl-zoo3's ``frame_stack`` hyperparameter: training stacks the normalised observations as rl-zoo3 does
(``VecFrameStack`` after ``VecNormalize``), :mod:`agents.evaluate` feeds the model the same stacks, and
``rl_zoo3.enjoy`` runs such a run; bad values are named."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from stable_baselines3 import PPO
from stable_baselines3.common.vec_env import VecFrameStack, VecNormalize

from agents.common import env_name, frame_stack_of, make_train_env, process_hyperparams, read_vecnormalize
from agents.evaluate import evaluate_agent, load_agent
from agents.train import train
from agents.warm_start import BehaviourCloningWarmStart

FORCE = "vsa_gym/ELPAS-ForceTracking-v0"
PS = "vsa_gym/VsaUT2-PositionStiffness-v0"
ENV_KWARGS = {"control_mode": "current", "max_episode_steps": 30}
STACK = 3


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    params = {"n_envs": 2, "n_steps": 64, "batch_size": 64, "n_epochs": 1, "frame_stack": STACK,
              "env_kwargs": dict(ENV_KWARGS)}
    info = train(FORCE, "ppo", 256, seed=0, log_folder=tmp_path_factory.mktemp("fs") / "logs", params=params,
                 save_freq=128, eval_freq=128, eval_episodes=1, tensorboard=False)
    assert info["status"] == "finished"
    return info


@pytest.mark.parametrize(("value", "n"), [(None, 1), (1, 1), (4, 4), (4.0, 4)])
def test_frame_stack_entry_is_a_count_of_observations(value: Any, n: int) -> None:
    assert frame_stack_of(value) == n
    raw = {"n_timesteps": 10} if value is None else {"n_timesteps": 10, "frame_stack": value}
    assert process_hyperparams(raw, 1)["frame_stack"] == n


@pytest.mark.parametrize("value", [0, -2, 2.5, float("inf"), float("nan"), "2", True])
def test_a_bad_frame_stack_is_named(value: Any) -> None:
    with pytest.raises(ValueError, match="frame_stack must be a whole number"):
        process_hyperparams({"n_timesteps": 10, "frame_stack": value}, 1)


def test_evaluation_feeds_the_model_the_stacks_it_was_trained_on(run: dict[str, Any]) -> None:
    model_path = Path(run["model"])
    agent = load_agent(model_path)
    d = make_train_env(FORCE, 1, 0, ENV_KWARGS, None).observation_space.shape[0]
    assert agent.model.observation_space.shape == (STACK * d,)
    steps, seed = 25, 123
    ev = evaluate_agent(model_path, FORCE, episodes=1, seed_base=seed, episode_steps=steps)
    assert ev["agent"]["frame_stack"] == STACK
    # the training chain (VecNormalize with the run's statistics, frozen, then VecFrameStack) driven by the model
    stats = Path(run["save_path"]) / env_name(FORCE) / "vecnormalize.pkl"
    venv = make_train_env(FORCE, 1, seed, {"control_mode": "current"}, None, vecnormalize_path=stats,
                          training=False, frame_stack=STACK)
    assert isinstance(venv, VecFrameStack) and isinstance(venv.venv, VecNormalize)
    raw = make_train_env(FORCE, 1, seed, {"control_mode": "current"}, None)  # what the evaluation policy sees
    obs, raw_obs, ret = venv.reset(), raw.reset(), 0.0
    agent.reset()
    for _ in range(steps):
        action, _ = agent.model.predict(obs, deterministic=True)
        np.testing.assert_allclose(agent(raw_obs), action, rtol=1e-5, atol=1e-8)  # the same input, step by step
        obs, r, _, _ = venv.step(action)
        raw_obs = raw.step(action)[0]
        ret += float(venv.venv.get_original_reward()[0])
    assert ev["return"] == pytest.approx(ret, rel=1e-5)
    # zeros before the episode's first observation, and the model's actions depend on the older frames
    vn = read_vecnormalize(stats)
    o = np.ones((1, d), dtype=np.float32)
    agent.reset()
    first = agent(o)
    np.testing.assert_array_equal(agent.frames[0, :-d], 0.0)
    np.testing.assert_allclose(agent.frames[0, -d:], vn.normalize_obs(o)[0], rtol=1e-6)
    agent(o)
    third = agent(o)  # the same observation, now in every frame
    assert np.abs(third - first).max() > 1e-6
    agent.reset()
    np.testing.assert_array_equal(agent(o), first)


def test_rl_zoo3_enjoy_stacks_the_frames_of_our_run(run: dict[str, Any], monkeypatch: pytest.MonkeyPatch,
                                                     capsys: pytest.CaptureFixture[str]) -> None:
    import rl_zoo3.enjoy as zoo_enjoy

    built: list[Any] = []
    real = zoo_enjoy.create_test_env

    def recording(*args: Any, **kwargs: Any) -> Any:
        built.append(real(*args, **kwargs))
        return built[-1]

    monkeypatch.setattr(zoo_enjoy, "create_test_env", recording)
    monkeypatch.setattr(sys, "argv", ["enjoy", "--algo", "ppo", "--env", FORCE, "-f", run["log_folder"],
                                      "--exp-id", "1", "--gym-packages", "vsa_gym", "--no-render", "-n", "40",
                                      "--num-threads", "1", "--device", "cpu"])
    zoo_enjoy.enjoy()
    assert isinstance(built[0], VecFrameStack) and built[0].observation_space.shape[0] % STACK == 0
    assert "Episode Length 30" in capsys.readouterr().out


def test_the_warm_start_refuses_stacked_frames() -> None:
    env = make_train_env(PS, 2, 0, None, {"norm_obs": True, "norm_reward": False}, frame_stack=2)
    model = PPO("MlpPolicy", env, n_steps=16, batch_size=32, seed=0)
    with pytest.raises(ValueError, match="stacked frames"):
        model.learn(32, callback=BehaviourCloningWarmStart("decoupled", steps=10))
