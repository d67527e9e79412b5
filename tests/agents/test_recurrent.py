"""Recurrent agents (rl-zoo3's ``ppo_lstm``, sb3-contrib's ``RecurrentPPO``): trained and saved in the run layout,
evaluated with the LSTM state carried from step to step exactly as the training chain runs them, loaded by
``rl_zoo3.enjoy``, and refused by the behaviour-cloning warm start."""

from __future__ import annotations

import shutil
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from agents.common import algo_of_model, checkpoints, env_name, make_train_env
from agents.evaluate import agent_policy, evaluate_agent, load_agent
from agents.train import train
from agents.warm_start import BehaviourCloningWarmStart
from tests.agents.conftest import tiny

FORCE = "vsa_gym/ELPAS-ForceTracking-v0"


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    info = train(FORCE, "ppo_lstm", 512, seed=0, log_folder=tmp_path_factory.mktemp("lstm") / "logs",
                 params=tiny("ppo_lstm"), save_freq=256, eval_freq=256, eval_episodes=2, n_eval_envs=2,
                 tensorboard=False)
    assert info["status"] == "finished"
    return info


def test_a_recurrent_run_has_the_layout_and_its_algorithm_is_read_back(run: dict[str, Any], tmp_path: Path) -> None:
    save = Path(run["save_path"])
    assert save.parent.name == "ppo_lstm" and (save / "best_model.zip").exists()
    assert [n for n, _ in checkpoints(save, off_policy=False, normalized=True)] == [256, 512]
    elsewhere = tmp_path / "model.zip"  # outside the layout: the algorithm comes from the zip
    shutil.copy(save / f"{env_name(FORCE)}.zip", elsewhere)
    assert algo_of_model(elsewhere) == "ppo_lstm"
    assert load_agent(run["model"]).recurrent


def test_evaluation_carries_the_lstm_state_as_training_does(run: dict[str, Any]) -> None:
    model_path = Path(run["model"])
    factory, kw, _ = agent_policy(model_path, FORCE)
    agent = load_agent(model_path)
    steps, seed = 40, 77
    ev = evaluate_agent(model_path, FORCE, episodes=1, seed_base=seed, episode_steps=steps)
    stats = Path(run["save_path"]) / env_name(FORCE) / "vecnormalize.pkl"
    venv = make_train_env(FORCE, 1, seed, kw, None, vecnormalize_path=stats, training=False)
    raw = make_train_env(FORCE, 1, seed, kw, None)
    obs, raw_obs, ret, state, start = venv.reset(), raw.reset(), 0.0, None, np.ones(1, dtype=bool)
    for _ in range(steps):
        action, state = agent.model.predict(obs, state=state, episode_start=start, deterministic=True)
        start = np.zeros(1, dtype=bool)
        np.testing.assert_allclose(agent(raw_obs), action, rtol=1e-5, atol=1e-8)
        obs, _, _, _ = venv.step(action)
        raw_obs = raw.step(action)[0]
        ret += float(venv.get_original_reward()[0])
    assert ev["return"] == pytest.approx(ret, rel=1e-5)
    # the policy has memory: the same observation gives another action once the state has moved; reset() forgets
    o = np.ones((1, agent.model.observation_space.shape[0]), dtype=np.float32)
    agent.reset()
    first = agent(o)
    later = [agent(o) for _ in range(5)][-1]
    assert np.abs(later - first).max() > 1e-7
    agent.reset()
    np.testing.assert_array_equal(agent(o), first)


def test_rl_zoo3_enjoy_runs_a_recurrent_run(run: dict[str, Any], monkeypatch: pytest.MonkeyPatch,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    import rl_zoo3.enjoy as zoo_enjoy

    monkeypatch.setattr(sys, "argv", ["enjoy", "--algo", "ppo_lstm", "--env", FORCE, "-f", run["log_folder"],
                                      "--exp-id", "1", "--gym-packages", "vsa_gym", "--no-render", "-n", "120",
                                      "--num-threads", "1", "--device", "cpu"])
    zoo_enjoy.enjoy()
    out = capsys.readouterr().out
    assert f"Loading {Path(run['save_path']) / (env_name(FORCE) + '.zip')}" in out and "Episode Length 100" in out


def test_the_warm_start_refuses_a_recurrent_policy() -> None:
    from sb3_contrib import RecurrentPPO

    env = make_train_env(FORCE, 2, 0, {"control_mode": "current"}, None)
    model = RecurrentPPO("MlpLstmPolicy", env, n_steps=16, batch_size=32, seed=0)
    with pytest.raises(TypeError, match="feed-forward actor-critic"):
        model.learn(32, callback=BehaviourCloningWarmStart("cascade", steps=10))
