"""The Throw task's potential-based progress shaping (issue 18): dense, yet no policy's discounted return changes."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import vsa_gym  # noqa: F401
from baselines.vsaut2_throw import bang_bang

THROW = "vsa_gym/VsaUT2-Throw-v0"


def _episode(schedule: np.ndarray | None, **kw: float) -> tuple[np.ndarray, np.ndarray, dict]:
    env = gym.make(THROW, **kw)
    env.reset(seed=0)
    rewards, progress = [], []
    for k in range(500):
        a = schedule[k // 10] if schedule is not None and k // 10 < len(schedule) else np.zeros(2)
        _, r, term, trunc, info = env.step(a.astype(np.float32))
        rewards.append(r)
        progress.append(info["reward_progress"])
        if term or trunc:
            return np.array(rewards), np.array(progress), info
    raise AssertionError("the time limit must end the episode")


@pytest.mark.parametrize("schedule", [bang_bang(30, 0.5, 0, 0), bang_bang(30, 0.3, 4, 8), None],
                         ids=["release", "other release", "no release"])
@pytest.mark.parametrize("gamma", [1.0, 0.99])
def test_shaping_leaves_every_discounted_return_unchanged(schedule: np.ndarray | None, gamma: float) -> None:
    plain, zero, info0 = _episode(schedule)
    shaped, prog, info1 = _episode(schedule, shaping=1.0, shaping_gamma=gamma)
    assert np.all(zero == 0.0)  # no shaping by default: the reward is the release speed alone
    np.testing.assert_allclose(shaped - prog, plain, rtol=1e-12, atol=1e-12)  # the other terms are untouched
    assert info1["release_speed"] == info0["release_speed"]  # the scored metric is the same
    if schedule is not None:
        assert np.count_nonzero(prog) > 0.9 * len(prog)  # dense: a signal on (almost) every step
    # Phi(s0) = 0 at rest and Phi = 0 once the episode ends: the discounted sums agree (Ng et al. 1999)
    disc = gamma ** np.arange(len(plain))
    assert float(disc @ shaped) == pytest.approx(float(disc @ plain), abs=1e-9)


def test_shaping_rewards_progress_towards_the_release() -> None:
    """Before the release, swinging towards the release angle earns more than standing still."""
    _, prog_swing, _ = _episode(bang_bang(30, 0.5, 0, 0), shaping=1.0, shaping_gamma=1.0)
    _, prog_rest, _ = _episode(None, shaping=1.0, shaping_gamma=1.0)
    assert prog_swing[:50].sum() > 1.0 and abs(prog_rest[:50].sum()) < 1e-6


def test_shaping_arguments_are_checked() -> None:
    with pytest.raises(ValueError, match="shaping must"):
        gym.make(THROW, shaping=-1.0)
    with pytest.raises(ValueError, match="shaping_gamma"):
        gym.make(THROW, shaping_gamma=0.0)


def test_pushing_hard_spends_the_budget_before_the_release() -> None:
    """Why random exploration rarely releases (docs/agents.md, "Throw with an action hold"): a constant full frame
    voltage spends the 5 J budget, the drives switch off and the bar never reaches the release angle; half of it
    releases."""
    for level, releases in ((1.0, False), (0.5, True)):
        env = gym.make(THROW)
        env.reset(seed=0)
        for _ in range(500):
            _, _, term, trunc, info = env.step(np.array([0.0, level], dtype=np.float32))
            if term or trunc:
                break
        assert bool(info["released"]) == releases
        if not releases:
            assert trunc and not info["drive_enabled"] and info["margin_energy"] <= 0.0
