"""Leaky-integral observation features: the filter's equation, episode restarts, training == evaluation."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from agents.common import make_train_env
from agents.evaluate import wrapped_policy
from agents.features import FEATURE_CLASS, LeakyIntegral, feature_config
from baselines.metrics import evaluate_policy

QC = "vsa_gym/ELPAS-QuarterCar-v0"
CURRENT = {"control_mode": "current"}
FEATURE = {FEATURE_CLASS: {"channels": ["body_accel"], "leak_hz": 0.3}}


def test_filter_is_a_scaled_leaky_integral() -> None:
    dt, f = 2e-3, 0.5
    filt = LeakyIntegral(["a", "b"], ["b"], dt, f)
    u = np.random.default_rng(0).normal(size=(400, 2))
    z = np.stack([filt.update(u[k][None])[0] for k in range(len(u))])[:, 0]
    lam = np.exp(-2 * np.pi * f * dt)
    want = (1 - lam) / dt * signal.lfilter([dt], [1.0, -lam], u[:, 1])
    np.testing.assert_allclose(z, want, rtol=1e-5, atol=1e-7)
    filt.reset(1)
    const = np.stack([filt.update(np.array([[0.0, 3.0]]))[0] for _ in range(20000)])
    assert const[-1, 0] == pytest.approx(3.0, rel=1e-4)  # settles at the input: the channel's own units
    lo, hi = filt.bounds(np.array([-1.0, -3.0]), np.array([1.0, 3.0]))
    assert hi[0] >= const.max() and lo[0] == -hi[0]


def test_bad_channel_and_corner_are_named() -> None:
    with pytest.raises(ValueError, match="unknown observation channel.*'nope'"):
        LeakyIntegral(["a"], ["nope"], 1e-3, 0.3)
    with pytest.raises(ValueError, match="leak_hz"):
        LeakyIntegral(["a"], ["a"], 1e-3, 0.0)


def test_wrapper_restarts_ended_rows_and_keeps_their_last_integral() -> None:
    venv = make_train_env(QC, 2, 3, {**CURRENT, "max_episode_steps": 7}, None, vec_env_wrapper=[FEATURE])
    obs = venv.reset()
    assert obs.shape == (2, 8)
    f = venv.venv.filter  # VecMonitor -> LeakyIntegralVecEnv
    k = list(venv.get_attr("unwrapped", [0])[0].task.obs_channels).index(
        next(c for c in venv.get_attr("unwrapped", [0])[0].task.obs_channels if c.name == "body_accel"))
    z = f.gain * f.dt * obs[:, k].astype(np.float64)
    np.testing.assert_allclose(obs[:, -1], z, rtol=1e-5)
    act = np.full((2, 1), 0.3, dtype=np.float32)
    for step in range(1, 8):
        obs, _, done, infos = venv.step(act)
        if step < 7:
            assert not done.any()
            z = f.leak * z + f.gain * f.dt * obs[:, k]
            np.testing.assert_allclose(obs[:, -1], z, rtol=1e-4, atol=1e-9)
    assert done.all()  # the time limit ends both rows together
    for i in range(2):
        term = infos[i]["terminal_observation"]
        np.testing.assert_allclose(term[-1], f.leak * z[i] + f.gain * f.dt * term[k], rtol=1e-4, atol=1e-9)
    np.testing.assert_allclose(obs[:, -1], f.gain * f.dt * obs[:, k], rtol=1e-5)  # fresh episodes start at 0


def _feature_agent(obs: np.ndarray) -> np.ndarray:
    o = np.atleast_2d(obs)
    return np.clip(-2.0 * o[:, -1:], -1.0, 1.0).astype(np.float32)  # acts on the feature only


@pytest.mark.parametrize("residual", [False, True])
def test_evaluation_rebuilds_what_training_saw(residual: bool) -> None:
    steps, seeds = 80, [5]
    wrappers = ([{"agents.residual.ResidualVecEnv": {"baseline": "skyhook", "scale": 0.5}}] if residual else [])
    wrappers.append(FEATURE)
    assert feature_config(wrappers) == FEATURE[FEATURE_CLASS]
    venv = make_train_env(QC, 1, seeds[0], CURRENT, None, vec_env_wrapper=wrappers)
    obs, ret = venv.reset(), 0.0
    assert obs.shape == (1, 9 if residual else 8)
    for _ in range(steps):
        obs, r, _, _ = venv.step(_feature_agent(obs))
        ret += float(r[0])
    ev = evaluate_policy(QC, wrapped_policy(_feature_agent, wrappers), seeds, episode_steps=steps, env_kwargs=CURRENT)
    assert ev["return"] == pytest.approx(ret, rel=1e-5)
    plain = evaluate_policy(QC, wrapped_policy(_feature_agent, wrappers[:-1] or None), seeds, episode_steps=steps,
                            env_kwargs=CURRENT)
    assert plain["return"] != pytest.approx(ret, rel=1e-6)  # the agent's action depends on the feature
