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


def test_low_pass_is_the_skyhook_speed_estimate() -> None:
    """With ``lp_hz`` the feature is the leaky integral (unit DC gain) behind a first-order low-pass: the
    cascade of the two recursions, checked against scipy; ``peek`` gives what ``update`` then returns."""
    dt, f, f_lp = 2e-3, 0.3, 1.5
    filt = LeakyIntegral(["a", "b"], ["b"], dt, f, lp_hz=f_lp)
    u = np.random.default_rng(1).normal(size=(600, 2))
    filt.reset(1)
    got = []
    for k in range(len(u)):
        nxt = filt.peek(u[k][None], np.array([0]))
        got.append(filt.update(u[k][None])[0])
        np.testing.assert_array_equal(nxt[0], got[-1])
    lam, beta = np.exp(-2 * np.pi * f * dt), 1 - np.exp(-2 * np.pi * f_lp * dt)
    v = (1 - lam) / dt * signal.lfilter([dt], [1.0, -lam], u[:, 1])
    want = signal.lfilter([beta], [1.0, -(1 - beta)], v)
    np.testing.assert_allclose(np.array(got)[:, 0], want, rtol=1e-5, atol=1e-7)
    plain = LeakyIntegral(["a", "b"], ["b"], dt, f)
    assert not np.allclose([plain.update(x[None])[0, 0] for x in u], want, rtol=1e-3)  # the low-pass acts
    filt.reset(1)
    const = np.stack([filt.update(np.array([[0.0, 3.0]]))[0] for _ in range(20000)])
    assert const[-1, 0] == pytest.approx(3.0, rel=1e-4)  # still a unit DC gain


def test_bad_channel_and_corner_are_named() -> None:
    with pytest.raises(ValueError, match="unknown observation channel.*'nope'"):
        LeakyIntegral(["a"], ["nope"], 1e-3, 0.3)
    with pytest.raises(ValueError, match="leak_hz"):
        LeakyIntegral(["a"], ["a"], 1e-3, 0.0)
    with pytest.raises(ValueError, match="lp_hz"):
        LeakyIntegral(["a"], ["a"], 1e-3, 0.3, lp_hz=float("nan"))


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


@pytest.mark.parametrize(("residual", "lp_hz"), [(False, None), (True, None), (False, 1.5)])
def test_evaluation_rebuilds_what_training_saw(residual: bool, lp_hz: float | None) -> None:
    steps, seeds = 80, [5]
    wrappers = ([{"agents.residual.ResidualVecEnv": {"baseline": "skyhook", "scale": 0.5}}] if residual else [])
    feature = {FEATURE_CLASS: {**FEATURE[FEATURE_CLASS], **({} if lp_hz is None else {"lp_hz": lp_hz})}}
    wrappers.append(feature)
    assert feature_config(wrappers) == feature[FEATURE_CLASS]
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
