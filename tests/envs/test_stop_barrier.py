"""The force-tracking task's ``stop`` term: a training-only price on approaching the gamma end stop.

Checked: the term's law against ``info["margin_gamma_stop"]`` on a rollout that drives the arm into its stop
(the drive's software travel limit switched off for it),
zero by default and farther than ``stop_width`` from the stop, the reward is the sum of its terms, the term
changes nothing else (same dynamics, observations and episode end), single env == native vector env, and
bad weights are named.
"""
from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import vsa_gym  # noqa: F401  (registers the environments)
from vsa_gym.envs.task import stop_barrier

ENV_ID = "vsa_gym/ELPAS-ForceTracking-v0"


def _drive_into_stop(env: gym.Env, seed: int = 1) -> tuple[list[np.ndarray], list[dict], list[float], bool]:
    """Full negative current command (the arm turns towards +90 deg) until the episode ends or 600 steps."""
    obs, _ = env.reset(seed=seed)
    observations, infos, rewards = [obs], [], []
    term = False
    for _ in range(600):
        obs, r, term, trunc, info = env.step(np.array([-1.0], dtype=np.float32))
        observations.append(obs)
        infos.append(info)
        rewards.append(float(r))
        if term or trunc:
            break
    return observations, infos, rewards, bool(term)


def test_stop_barrier_law() -> None:
    assert stop_barrier(0.5, 10.0, 0.4) == 0.0
    assert stop_barrier(0.4, 10.0, 0.4) == 0.0
    assert stop_barrier(0.2, 10.0, 0.4) == pytest.approx(-2.5)
    assert stop_barrier(0.0, 10.0, 0.4) == pytest.approx(-10.0)
    assert stop_barrier(-0.1, 10.0, 0.4) == pytest.approx(-10.0 * 1.25 ** 2)
    assert stop_barrier(0.1, 0.0, 0.4) == 0.0


def test_default_band_leaves_the_reference_range_free() -> None:
    """The default ``stop_width`` (0.4 rad before the +-90 deg stop) starts beyond the arm angle at which the static
    force at alpha = 0 reaches the top of the reference range: tracking any reference needs no priced angle there."""
    from vsa_gym.devices.elpas.cone import spring_unchecked
    from vsa_gym.devices.elpas.params import ElpasParams

    env = gym.make(ENV_ID)
    task = env.unwrapped.task
    width = task.stop_width
    top = next(c.high for c in task.obs_channels if c.name == "force_ref")
    gamma_free = np.pi / 2 - width
    assert np.rad2deg(gamma_free) == pytest.approx(67.1, abs=0.1)
    cone = ElpasParams().cone
    assert float(spring_unchecked(cone, np.array([gamma_free]), np.array([0.0])).F_act[0]) > top


def test_stop_term_prices_the_approach_and_changes_nothing_else() -> None:
    w, width = 7.0, 0.4
    # without the drive's software travel limit, so that the rollout reaches the stop
    plain = gym.make(ENV_ID, control_mode="current", soft_limit=None)
    priced = gym.make(ENV_ID, control_mode="current", soft_limit=None, w_stop=w, stop_width=width)
    obs0, info0, r0, term0 = _drive_into_stop(plain)
    obs1, info1, r1, term1 = _drive_into_stop(priced)
    assert term0 and term1 and len(r0) == len(r1)  # the same episode end at the same step
    np.testing.assert_array_equal(np.array(obs0), np.array(obs1))
    margins = np.array([i["margin_gamma_stop"] for i in info1])
    assert margins[0] > width and margins[-1] <= 0.0  # the rollout crosses the whole barrier
    stop = np.array([i["reward_stop"] for i in info1])
    expected = -w * np.clip(1.0 - margins / width, 0.0, None) ** 2
    np.testing.assert_allclose(stop, expected, rtol=1e-12, atol=1e-12)
    assert stop[-1] <= -w and np.all(stop[margins > width] == 0.0)
    assert all(i["reward_stop"] == 0.0 for i in info0)  # off by default
    np.testing.assert_allclose(np.array(r1) - np.array(r0), stop, rtol=0, atol=1e-9)
    terms = ("force", "energy", "failure", "stop")
    np.testing.assert_allclose(r1, [sum(i[f"reward_{t}"] for t in terms) for i in info1], rtol=1e-12, atol=1e-12)


def test_stop_term_single_equals_vector() -> None:
    kw = dict(control_mode="current", w_stop=5.0, stop_width=0.6, soft_limit=None)
    single = gym.make(ENV_ID, **kw)
    _, infos, rewards, _ = _drive_into_stop(single, seed=3)
    venv = gym.make_vec(ENV_ID, num_envs=2, vectorization_mode="vector_entry_point", **kw)
    venv.reset(seed=[3, 4])
    for k, r in enumerate(rewards):
        _, rv, term, _, info = venv.step(np.full((2, 1), -1.0, dtype=np.float32))
        assert rv[0] == pytest.approx(r, rel=1e-12, abs=1e-12)
        assert info["reward_stop"][0] == pytest.approx(infos[k]["reward_stop"], rel=1e-12, abs=1e-12)
        if term[0]:
            break


@pytest.mark.parametrize("kw, match", [({"w_stop": -1.0}, "w_stop"), ({"w_stop": float("nan")}, "w_stop"),
                                       ({"stop_width": 0.0}, "stop_width"),
                                       ({"stop_width": float("inf")}, "stop_width")])
def test_bad_stop_weights_are_named(kw: dict, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        gym.make(ENV_ID, **kw)
