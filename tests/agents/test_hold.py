"""Action hold: one agent step is k control steps with the same action; episode ends inside a hold; the
evaluation-time policy holds the same way."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from stable_baselines3.common.vec_env import DummyVecEnv

from agents.common import make_train_env
from agents.evaluate import wrapped_policy
from agents.hold import HOLD_CLASS, ActionHoldVecEnv, HoldPolicy, hold_config
from baselines.metrics import evaluate_policy

THROW = "vsa_gym/VsaUT2-Throw-v0"


def test_one_agent_step_is_k_control_steps_with_the_same_action() -> None:
    held = make_train_env(THROW, 2, 5, None, None, vec_env_wrapper=[{HOLD_CLASS: {"steps": 3}}])
    plain = make_train_env(THROW, 2, 5, None, None)
    np.testing.assert_array_equal(held.reset(), plain.reset())
    rng = np.random.default_rng(0)
    for _ in range(4):
        a = rng.uniform(-1, 1, size=(2, 2)).astype(np.float32)
        obs, rew, done, _ = held.step(a)
        want = np.zeros(2)
        for _ in range(3):
            o, r, d, _ = plain.step(a)
            want += r
            assert not d.any()
        np.testing.assert_array_equal(obs, o)
        np.testing.assert_allclose(rew, want, rtol=1e-6)
        assert not done.any()


class _Counter(gym.Env):
    """Observation: the control steps taken in this episode; reward 1 per step plus 100 x the action;
    the episode ends after ``length`` steps."""

    observation_space = gym.spaces.Box(0.0, 100.0, (1,), np.float32)
    action_space = gym.spaces.Box(-1.0, 1.0, (1,), np.float32)

    def __init__(self, length: int) -> None:
        self.length, self.k = length, 0

    def reset(self, *, seed: int | None = None, options: dict | None = None) -> tuple[np.ndarray, dict]:
        super().reset(seed=seed)
        self.k = 0
        return np.array([0.0], np.float32), {}

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict]:
        self.k += 1
        return np.array([self.k], np.float32), 1.0 + 100.0 * float(action[0]), self.k >= self.length, False, {}


def test_an_episode_that_ends_inside_a_hold_is_reported_once_and_the_row_idles() -> None:
    venv = ActionHoldVecEnv(DummyVecEnv([lambda: _Counter(4), lambda: _Counter(7)]), 3)
    venv.reset()
    a = np.full((2, 1), 0.5, dtype=np.float32)
    obs, rew, done, _ = venv.step(a)
    np.testing.assert_array_equal(obs[:, 0], [3, 3])
    np.testing.assert_allclose(rew, [153, 153])
    obs, rew, done, infos = venv.step(a)  # row 0 ends on its 4th step: one step's reward, then 2 idle steps
    np.testing.assert_array_equal(done, [True, False])
    np.testing.assert_allclose(rew, [51, 153])
    assert infos[0]["terminal_observation"][0] == 4
    np.testing.assert_array_equal(obs[:, 0], [2, 6])  # row 0: its new episode after the idle steps
    # row 1 ends on its 7th step (the hold's first), idles one step; row 0 ends on the hold's second step
    # (its steps 3 and 4 of 4); then every row has ended and the hold stops there
    obs, rew, done, _ = venv.step(a)
    np.testing.assert_array_equal(done, [True, True])
    np.testing.assert_allclose(rew, [102, 51])
    np.testing.assert_array_equal(obs[:, 0], [0, 1])


def test_the_evaluation_policy_asks_the_agent_every_k_calls() -> None:
    calls: list[int] = []

    def agent(obs: np.ndarray) -> np.ndarray:
        calls.append(1)
        return np.full((np.atleast_2d(obs).shape[0], 2), float(len(calls)), dtype=np.float32)

    pol = HoldPolicy(agent, 4)
    got = [float(pol(np.zeros((1, 3)))[0, 0]) for _ in range(9)]
    assert got == [1, 1, 1, 1, 2, 2, 2, 2, 3]
    pol.reset()
    assert float(pol(np.zeros((1, 3)))[0, 0]) == 4


def test_training_and_evaluation_hold_alike() -> None:
    """The same fixed agent through the wrapper and through agents.evaluate's rebuilt policy: same return."""
    def agent(obs: np.ndarray) -> np.ndarray:  # a frame swing that changes with the observed output angle
        o = np.atleast_2d(obs)
        return np.column_stack([np.full(len(o), 0.2), np.sign(np.sin(40 * o[:, 0] + 1.0))]).astype(np.float32)

    cfg = [{HOLD_CLASS: {"steps": 5}}]
    factory = wrapped_policy(agent, cfg)
    res = evaluate_policy(THROW, factory, seeds=[3], episode_steps=60)
    venv = make_train_env(THROW, 1, 3, None, None, vec_env_wrapper=cfg)
    obs, total = venv.reset(), 0.0
    for _ in range(12):
        obs, r, done, _ = venv.step(agent(obs))
        total += float(r[0])
        if done[0]:
            break
    assert total == pytest.approx(res["return"], rel=1e-6, abs=1e-9)
    assert hold_config(cfg) == {"steps": 5}


@pytest.mark.parametrize("steps", [0, -2, 2.5, True])
def test_a_bad_hold_length_is_named(steps: object) -> None:
    venv = make_train_env(THROW, 1, 0, None, None)
    with pytest.raises(ValueError, match="steps must be an integer >= 1"):
        ActionHoldVecEnv(venv, steps)  # type: ignore[arg-type]
