"""The vsaUT-II drives' I^2 t foldback (issue 18): the law, and that it keeps the drives out of the trip."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import vsa_gym  # noqa: F401
from vsa_gym.devices.vsaut2.params import re40_motor
from vsa_gym.physics.dc_motor import current_limited_voltage, foldback_current


def test_foldback_law() -> None:
    i_max, i_fold, lo, hi = 12.0, 3.0, 0.5, 0.9
    u = np.linspace(0.0, 1.2, 121)
    lim = np.array([foldback_current(i_max, i_fold, v, lo, hi) for v in u])
    assert np.all(lim[u <= lo] == i_max) and np.all(lim[u >= hi] == i_fold)
    assert np.all(np.diff(lim) <= 0.0)  # never rises with the heating state
    assert foldback_current(i_max, i_fold, 0.7, lo, hi) == pytest.approx(7.5)
    assert foldback_current(i_max, i_fold, 0.99, 1.0, 1.0) == i_max  # start == end: no foldback
    assert foldback_current(i_max, 20.0, 0.95, lo, hi) == i_max  # a fold level above I_max never raises it
    m = re40_motor()
    assert current_limited_voltage(m, 24.0, 10.0, m.I_max) == 24.0  # at I_max the amplifier's own limit acts
    assert current_limited_voltage(m, 24.0, 10.0, 3.0) == pytest.approx(m.k_e * 10.0 + m.R * 3.0)
    assert current_limited_voltage(m, -24.0, 10.0, 3.0) == pytest.approx(m.k_e * 10.0 - m.R * 3.0)


def _bang_bang(mode: str, fold: tuple[float, float] | None, steps: int = 5000) -> dict[str, float]:
    env = gym.make("vsa_gym/VsaUT2-PositionStiffness-v0", control_mode=mode, i2t_foldback=fold,
                   max_episode_steps=steps)
    env.reset(seed=3)
    task = env.unwrapped.task
    peak_util, sq, n_sq, finite = 0.0, np.zeros(2), 0, True
    for k in range(steps):
        a = np.array([1.0 if (k // 5) % 2 else -1.0, 1.0 if (k // 7) % 2 else -1.0], dtype=np.float32)
        obs, reward, term, trunc, info = env.step(a)
        finite &= bool(np.all(np.isfinite(obs)) and np.isfinite(reward))
        finite &= all(np.all(np.isfinite(v)) for v in info.values() if np.asarray(v).dtype.kind == "f")
        peak_util = max(peak_util, float(obs[9]), float(obs[10]))
        if k >= steps - 1000:  # the last 2 s: each drive's rms current
            sq += task.s["x"][0, [0, 3]] ** 2
            n_sq += 1
        if term or trunc:
            return {"steps": k + 1, "terminated": term, "peak_util": peak_util, "finite": finite,
                    "margin_i2t": float(info["margin_i2t"]), "i_rms": float(np.max(np.sqrt(sq / max(n_sq, 1))))}
    raise AssertionError("the time limit must end the episode")


@pytest.mark.parametrize("mode", ["voltage", "current"])
def test_foldback_keeps_the_drives_out_of_the_trip(mode: str) -> None:
    """Full-scale bang-bang commands trip the I^2 t protection within about 1000 steps (2 s) without the foldback;
    with it 10 s of them run to the time limit, the utilisation settles below 1 and each drive's rms current over
    the last 2 s is about the nominal 4 A (the heating state neither grows nor trips)."""
    off = _bang_bang(mode, None)
    assert off["terminated"] and off["margin_i2t"] <= 0.0 and off["steps"] < 1500
    on = _bang_bang(mode, (0.5, 0.9))
    assert on["finite"] and not on["terminated"] and on["steps"] == 5000
    assert 0.5 < on["peak_util"] < 0.95
    assert on["margin_i2t"] > 0.05
    assert on["i_rms"] < 4.5


def test_foldback_arguments_are_checked() -> None:
    with pytest.raises(ValueError, match="i2t_foldback"):
        gym.make("vsa_gym/VsaUT2-Throw-v0", i2t_foldback=(0.9, 0.5))
    with pytest.raises(ValueError, match="i_foldback"):
        gym.make("vsa_gym/VsaUT2-Throw-v0", i_foldback=0.0)
