"""ISO 2631-1 W_k weighting and weighted RMS."""

import numpy as np
import pytest
from scipy import signal

from vsa_gym.vehicle import comfort

# ISO 2631-1:1997 Table 3, W_k (factor x 1000)
TABLE = {0.5: 418, 1.0: 482, 2.0: 531, 4.0: 967, 5.0: 1039, 8.0: 1036, 10.0: 988, 16.0: 768, 31.5: 405}


def test_wk_analog_matches_the_standard_table() -> None:
    f = np.array(list(TABLE))
    np.testing.assert_allclose(comfort.wk_magnitude(f), np.array(list(TABLE.values())) / 1000.0, rtol=0.02)


def test_digital_filter_follows_the_analog_weighting() -> None:
    f = np.array([0.5, 1.0, 4.0, 8.0, 16.0, 31.5])
    _, h = signal.sosfreqz(comfort.wk_sos(1000.0), worN=f, fs=1000.0)
    np.testing.assert_allclose(np.abs(h), comfort.wk_magnitude(f), rtol=0.02)


def test_weighted_rms_of_a_sine() -> None:
    fs = 1000.0
    t = np.arange(0, 20.0, 1.0 / fs)
    for f0 in (1.0, 5.0):
        acc = 2.0 * np.sin(2 * np.pi * f0 * t)
        aw = comfort.weighted_rms(acc, fs, settle=5.0)
        assert aw == pytest.approx(2.0 / np.sqrt(2.0) * comfort.wk_magnitude(np.array([f0]))[0], rel=0.01)


def test_bad_comfort_inputs_are_rejected() -> None:
    with pytest.raises(ValueError, match="fs"):
        comfort.wk_sos(100.0)
    with pytest.raises(ValueError, match="acc"):
        comfort.weighted_rms(np.array([0.0, np.nan]), 1000.0)
