"""Residual agents: zero correction is the baseline, rows restart cleanly, training and evaluation compose alike."""

from __future__ import annotations

import argparse
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import rl_zoo3.exp_manager as rl_zoo3_exp
from stable_baselines3.common.vec_env import DummyVecEnv

from agents.common import HYPERPARAMS_DIR, make_train_env, process_hyperparams, read_hyperparams
from agents.evaluate import evaluate_agent
from agents.residual import ResidualVecEnv, baseline_factory, reset_rows, residual_policy
from agents.train import train, with_residual
from baselines.elpas_cascade import ElpasCascade
from baselines.metrics import evaluate_policy
from tests.agents.conftest import tiny
from vsa_gym.envs.sb3 import make_sb3_vec_env

FORCE = "vsa_gym/ELPAS-ForceTracking-v0"
CURRENT = {"control_mode": "current"}
RESIDUAL_YML = HYPERPARAMS_DIR / "ppo_residual.yml"


def _zero(obs: np.ndarray) -> np.ndarray:
    return np.zeros((np.atleast_2d(obs).shape[0], 1), dtype=np.float32)


def test_zero_correction_is_the_baseline_in_training_and_evaluation() -> None:
    steps, seeds = 60, [11, 12, 13]
    base = evaluate_policy(FORCE, baseline_factory("cascade"), seeds, episode_steps=steps, env_kwargs=CURRENT)
    comp = evaluate_policy(FORCE, residual_policy(_zero, {"baseline": "cascade", "scale": 0.3}), seeds,
                           episode_steps=steps, env_kwargs=CURRENT)
    assert comp["return"] == base["return"] and comp["energy_J"] == base["energy_J"]
    venv = make_train_env(FORCE, 3, seeds[0], CURRENT, None,
                          vec_env_wrapper=[{"agents.residual.ResidualVecEnv": {"baseline": "cascade"}}])
    obs = venv.reset()
    assert obs.shape == (3, 9)  # the observation carries the baseline's action
    ret = np.zeros(3)
    for _ in range(steps):
        obs, r, _, _ = venv.step(np.zeros((3, 1), dtype=np.float32))
        ret += r
    assert ret.mean() == pytest.approx(base["return"], rel=1e-5)
    # a non-zero correction changes what the environment receives
    venv.reset()
    _, r1, _, _ = venv.step(np.ones((3, 1), dtype=np.float32))
    venv.reset()
    _, r0, _, _ = venv.step(np.zeros((3, 1), dtype=np.float32))
    assert not np.allclose(r0, r1)


def test_ended_rows_restart_with_a_fresh_baseline() -> None:
    rng = np.random.default_rng(0)
    obs = rng.uniform(-1, 1, (3, 8)) * [1, 1, 0.2, 1, 10, 2000, 2500, 100]
    obs[:, 6] = 2500.0
    pol = ElpasCascade()
    for _ in range(20):
        pol(obs + rng.normal(0, 0.1, obs.shape))
    new = obs.copy()
    new[1, 6] = 3000.0
    fresh = ElpasCascade()
    a_fresh = fresh(new[[1]])
    reset_rows(pol, fresh, np.array([1]), 3)
    alone = ElpasCascade()
    alone(new[[1]])
    nxt = pol(new)
    np.testing.assert_allclose(nxt[1], alone(new[[1]])[0])  # row 1 continues exactly like a fresh controller
    assert a_fresh.shape == (1, 1) and not np.allclose(nxt[0], alone(new[[0]])[0])


def test_rl_zoo3_builds_the_residual_wrapper(tmp_path: Path) -> None:
    args = argparse.Namespace(algo="ppo", env=FORCE)
    zoo = rl_zoo3_exp.ExperimentManager(args, "ppo", FORCE, str(tmp_path), config=str(RESIDUAL_YML))
    raw, _ = zoo.read_hyperparameters()
    _, _, _, vec_wrapper = zoo._preprocess_hyperparams(dict(raw))
    assert zoo.env_kwargs == CURRENT
    dummy = vec_wrapper(DummyVecEnv([lambda: gym.make(FORCE, **CURRENT)]))  # rl-zoo3's own env stack
    native = vec_wrapper(make_sb3_vec_env(FORCE, n_envs=2, seed=0, **CURRENT))
    assert isinstance(dummy, ResidualVecEnv) and isinstance(native, ResidualVecEnv)
    assert dummy.reset().shape == (1, 9) and native.reset().shape == (2, 9)
    ours = process_hyperparams(read_hyperparams("ppo", FORCE, RESIDUAL_YML), n_actions=1)
    assert ours["vec_env_wrapper"] == raw["vec_env_wrapper"] and ours["env_kwargs"] == CURRENT
    with pytest.raises(ValueError, match="control_mode"):
        ResidualVecEnv(make_sb3_vec_env(FORCE, n_envs=1, seed=0), "cascade")  # voltage mode


def test_residual_smoke_train_and_evaluate(tmp_path: Path) -> None:
    params = with_residual(tiny("ppo", env_kwargs={"max_episode_steps": 100}), "cascade:0.2")
    assert params["env_kwargs"] == {"max_episode_steps": 100, "control_mode": "current"}
    info = train(FORCE, "ppo", 256, seed=1, log_folder=tmp_path, params=params, save_freq=0, eval_freq=0)
    assert info["status"] == "finished"
    res = evaluate_agent(info["model"], FORCE, episodes=2, episode_steps=40)
    assert res["agent"]["residual"] == {"baseline": "cascade", "scale": 0.2}
    assert res["agent"]["env_kwargs"]["control_mode"] == "current" and res["steps"] == 40


VSA = "vsa_gym/VsaUT2-PositionStiffness-v0"
SETPOINT = {"agents.residual.SetpointResidualVecEnv": {"baseline": "decoupled", "channels": [["r_ref"], ["log_K_ref"]],
                                                       "scales": [0.1, 0.5]}}


def _lead(obs: np.ndarray) -> np.ndarray:
    o = np.atleast_2d(obs)  # a setpoint agent that leads the position reference by its error
    return np.clip(np.stack([5.0 * o[:, 13], 0.2 * np.ones(o.shape[0])], axis=1), -1, 1).astype(np.float32)


def test_setpoint_residual_zero_shift_is_the_baseline_and_evaluation_matches_training() -> None:
    from agents.evaluate import wrapped_policy

    steps, seed = 120, 21
    base = evaluate_policy(VSA, baseline_factory("decoupled"), [seed, seed + 1], episode_steps=steps)
    zero = evaluate_policy(VSA, wrapped_policy(lambda o: np.zeros((np.atleast_2d(o).shape[0], 2), np.float32),
                                               [SETPOINT]), [seed, seed + 1], episode_steps=steps)
    assert zero["return"] == base["return"]
    venv = make_train_env(VSA, 2, seed, {"max_episode_steps": 50}, None, vec_env_wrapper=[SETPOINT])
    assert venv.action_space.shape == (2,) and venv.observation_space.shape == (15,)
    obs, ret = venv.reset(), np.zeros(2)
    ended = 0
    for _ in range(steps):  # the 50-step limit ends both rows twice: fresh baselines on the shifted references
        obs, r, done, _ = venv.step(_lead(obs))
        ret += r
        ended += int(done.all())
    assert ended == 2
    lead = evaluate_policy(VSA, wrapped_policy(_lead, [SETPOINT]), [seed, seed + 1], episode_steps=50)
    venv2 = make_train_env(VSA, 2, seed, {"max_episode_steps": 50}, None, vec_env_wrapper=[SETPOINT])
    obs, first = venv2.reset(), np.zeros(2)
    for _ in range(50):
        obs, r, _, _ = venv2.step(_lead(obs))
        first += r
    assert first.mean() == pytest.approx(lead["return"], rel=1e-5)
    assert lead["return"] != pytest.approx(evaluate_policy(VSA, baseline_factory("decoupled"), [seed, seed + 1],
                                                           episode_steps=50)["return"], rel=1e-6)


def test_setpoint_residual_names_bad_channels() -> None:
    bad = {"agents.residual.SetpointResidualVecEnv": {"baseline": "decoupled", "channels": [["r_ref"], ["nope"]],
                                                      "scales": [0.1, 0.5]}}
    with pytest.raises(ValueError, match="component 1: unknown observation channel.*nope"):
        make_train_env(VSA, 1, 0, None, None, vec_env_wrapper=[bad])
