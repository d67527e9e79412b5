"""The eLPAS drive's software travel limit (issue 18): the law, that it keeps full-scale commands off the gamma
end stops, that it acts only through the command, single env == vector env, and bad settings named.
"""
from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import vsa_gym  # noqa: F401  (registers the environments)
from vsa_gym.devices.elpas import model as em
from vsa_gym.devices.elpas.task import (
    SOFT_LIMIT_BAND,
    SOFT_LIMIT_DECEL_DEFAULT,
    SOFT_LIMIT_DEFAULT,
    SOFT_LIMIT_TAU,
    soft_limit_command,
)

FT = "vsa_gym/ELPAS-ForceTracking-v0"
LIM, DEC = SOFT_LIMIT_DEFAULT, SOFT_LIMIT_DECEL_DEFAULT


def test_soft_limit_law() -> None:
    assert soft_limit_command(-1.0, 1.3, 5.0, LIM, DEC) == -1.0  # away from the stop: unchanged
    assert soft_limit_command(1.0, 0.5, 1.0, LIM, DEC) == 1.0  # far and slow: unchanged
    assert soft_limit_command(0.3, 0.0, 0.0, LIM, DEC) == 0.3
    d = 0.2  # on the braking curve the command towards the stop is capped at 0
    v = np.sqrt(2.0 * DEC * d)
    assert soft_limit_command(1.0, LIM - d, v, LIM, DEC) == pytest.approx(0.0, abs=1e-12)
    assert soft_limit_command(1.0, LIM - d, v - 0.25 * SOFT_LIMIT_BAND, LIM, DEC) == pytest.approx(0.25)
    assert soft_limit_command(1.0, LIM - d, v + SOFT_LIMIT_BAND, LIM, DEC) == pytest.approx(-1.0)
    assert soft_limit_command(1.0, LIM - d, v + 3.0, LIM, DEC) == -1.0  # never beyond full reverse
    # near the limit the curve is linear (|d| / tau); beyond it, at rest, the drive pushes back inside
    slope = 1.0 / SOFT_LIMIT_TAU / SOFT_LIMIT_BAND
    assert soft_limit_command(1.0, LIM - 0.001, 0.0, LIM, DEC) == pytest.approx(0.001 * slope)
    assert soft_limit_command(0.0, LIM + 0.005, 0.0, LIM, DEC) == pytest.approx(-0.005 * slope)
    # mirror symmetric about gamma = 0
    rng = np.random.default_rng(0)
    for c, g, s in zip(rng.uniform(-1, 1, 200), rng.uniform(0.01, 1.6, 200), rng.uniform(-8, 8, 200), strict=True):
        assert soft_limit_command(-c, -g, -s, LIM, DEC) == pytest.approx(-soft_limit_command(c, g, s, LIM, DEC))
    # continuous in the angle (no jump where the curve turns linear, nor at the limit)
    g = np.linspace(LIM - 0.3, LIM + 0.05, 20001)
    caps = np.array([soft_limit_command(1.0, x, 2.0, LIM, DEC) for x in g])
    assert np.max(np.abs(np.diff(caps))) < 0.01


def _rollout(env: gym.Env, pattern: str, steps: int = 3000, seed: int = 3) -> dict[str, float]:
    env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    a, peak, finite = 0.0, 0.0, True
    for k in range(steps):
        burst = pattern == "bursts" and k % 50 == 0
        a = float(rng.choice([-1.0, 1.0])) if burst else (a if pattern == "bursts" else float(pattern))
        obs, r, term, trunc, info = env.step(np.array([a], dtype=np.float32))
        finite &= bool(np.all(np.isfinite(obs)) and np.isfinite(r))
        peak = max(peak, abs(float(env.unwrapped.task.s["x"][0, em.GAMMA])))
        if term or trunc:
            break
    return {"steps": k + 1, "terminated": bool(term), "peak": peak, "margin": float(info["margin_gamma_stop"]),
            "finite": finite}


@pytest.mark.parametrize("mode", ["current", "voltage"])
@pytest.mark.parametrize("pattern", ["1.0", "-1.0", "bursts"])
def test_soft_limit_keeps_full_commands_off_the_end_stop(mode: str, pattern: str) -> None:
    """Without the limit full-scale commands turn the arm into a +-90 deg end stop within 1 s; with it they run
    3 s to the end and the arm stays within a degree and a half of the 80 deg limit."""
    off = _rollout(gym.make(FT, control_mode=mode, soft_limit=None), pattern)
    assert off["terminated"] and off["margin"] <= 0.0 and off["steps"] < 1000
    on = _rollout(gym.make(FT, control_mode=mode), pattern)
    assert on["finite"] and not on["terminated"] and on["steps"] == 3000
    assert LIM - 0.1 < on["peak"] < LIM + np.deg2rad(1.5)  # it went up to the limit, not beyond


def test_soft_limit_acts_only_through_the_command() -> None:
    """Voltage mode without noise: the command the drive applies is the law at the drive's encoder angle and speed
    estimate (the observation's first two channels, before their float32 rounding), and an env without the limit
    fed that command follows exactly the same trajectory."""
    limited = gym.make(FT, control_mode="voltage")
    twin = gym.make(FT, control_mode="voltage", soft_limit=None)
    limited.reset(seed=2)
    twin.reset(seed=2)
    s = limited.unwrapped.task.s
    sgn = np.sign(limited.unwrapped.task.params.drive.N)
    changed = 0
    for k in range(1500):
        a = 1.0 if (k // 400) % 2 == 0 else -1.0
        applied = sgn * soft_limit_command(sgn * a, float(s["meas"][0, 0]), float(s["vel"][0, 0]), LIM, DEC)
        changed += applied != a
        obs, r, term, _, info = limited.step(np.array([a]))
        obs2, r2, term2, _, info2 = twin.step(np.array([applied]))
        np.testing.assert_array_equal(obs, obs2)
        assert info["energy_el"] == info2["energy_el"] and r == r2 and not term and not term2
    assert changed > 100  # the limit did act


def test_soft_limit_single_equals_vector() -> None:
    single = [gym.make(FT, control_mode="current") for _ in range(2)]
    venv = gym.make_vec(FT, num_envs=2, vectorization_mode="vector_entry_point", control_mode="current")
    venv.reset(seed=[5, 6])
    for e, s in zip(single, (5, 6), strict=True):
        e.reset(seed=s)
    for _ in range(600):
        acts = np.array([[1.0], [-1.0]], dtype=np.float32)
        ov, _, _, _, _ = venv.step(acts)
        for j, e in enumerate(single):
            o, *_ = e.step(acts[j])
            np.testing.assert_array_equal(ov[j], o)


@pytest.mark.parametrize("kw, match", [({"soft_limit": np.pi / 2}, "soft_limit"), ({"soft_limit": 0.0}, "soft_limit"),
                                       ({"soft_limit": float("nan")}, "soft_limit"),
                                       ({"soft_limit_decel": 0.0}, "soft_limit_decel"),
                                       ({"soft_limit_decel": float("inf")}, "soft_limit_decel")])
def test_bad_soft_limit_settings_are_named(kw: dict, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        gym.make(FT, **kw)
    with pytest.raises(ValueError, match=match):
        gym.make("vsa_gym/ELPAS-QuarterCar-v0", **kw)
