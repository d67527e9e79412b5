"""ISO 8608 road profiles: PSD per class, reproducibility, input checks."""

import numpy as np
import pytest
from scipy import signal

from vsa_gym.vehicle import road


@pytest.mark.parametrize("road_class", ["A", "C", "H"])
def test_profile_psd_matches_its_class_within_10_percent(road_class: str) -> None:
    dx = 0.05
    prof = road.generate_profile(road_class, 4000.0, seed=1, dx=dx)
    f, psd = signal.welch(prof.h, fs=1.0 / dx, nperseg=8192)
    # octave bands across the ISO band (Welch estimate, independent of the synthesis grid)
    edges = 0.02 * 2.0 ** np.arange(8)  # 0.02 .. 2.56 cycles/m
    for lo, hi in zip(edges[:-1], edges[1:], strict=True):
        m = (f >= lo) & (f < hi)
        ratio = np.trapezoid(psd[m], f[m]) / np.trapezoid(road.iso8608_psd(f[m], road_class), f[m])
        assert ratio == pytest.approx(1.0, rel=0.10), (lo, hi, ratio)


def test_classes_step_by_factor_four_and_seed_reproducible() -> None:
    assert road.class_gd_n0("A") == pytest.approx(16e-6)
    assert road.class_gd_n0("D") / road.class_gd_n0("C") == pytest.approx(4.0)
    a = road.generate_profile("B", 500.0, seed=3)
    b = road.generate_profile("B", 500.0, seed=3)
    c = road.generate_profile("B", 500.0, seed=4)
    np.testing.assert_array_equal(a.h, b.h)
    assert not np.allclose(a.h, c.h)


def test_time_signal_follows_speed() -> None:
    prof = road.generate_profile("C", 1000.0, seed=2)
    h = road.time_signal(prof, speed=20.0, dt=1e-3, n_steps=1000)
    np.testing.assert_allclose(h[::50], np.interp(np.arange(0, 21.0, 1.0), prof.x, prof.h))


def test_bad_road_inputs_are_rejected() -> None:
    prof = road.generate_profile("C", 200.0, seed=2)
    with pytest.raises(ValueError, match="speed"):
        road.time_signal(prof, speed=-1.0, dt=1e-3, n_steps=10)
    with pytest.raises(ValueError, match="speed"):
        road.road_signal("C", speed=-5.0, duration=1.0, dt=1e-3, seed=0)
    with pytest.raises(ValueError, match="road_class"):
        road.class_gd_n0("Z")
    with pytest.raises(ValueError, match="n_max"):
        road.generate_profile("A", 100.0, seed=0, dx=0.5)
