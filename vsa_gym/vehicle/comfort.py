"""ISO 2631-1 ride comfort: the W_k frequency weighting (vertical) and the weighted RMS acceleration.

W_k is the product of four analog sections (ISO 2631-1:1997, Annex A, Table A.2)::

    band limit  H_h = s^2 / (s^2 + sqrt2 w1 s + w1^2)             f1 = 0.4 Hz  (high-pass)
                H_l = w2^2 / (s^2 + sqrt2 w2 s + w2^2)            f2 = 100 Hz  (low-pass)
    a-v trans.  H_t = (1 + s/w3) / (1 + s/(Q4 w4) + s^2/w4^2)     f3 = f4 = 12.5 Hz, Q4 = 0.63
    upward step H_s = (s^2 + w5 s/Q5 + w5^2) / (s^2 + w6 s/Q6 + w6^2)
                                                                  f5 = 2.37 Hz, Q5 = 0.91, f6 = 3.35 Hz, Q6 = 0.91

(``w = 2 pi f``).  Note: the standard's upward step has ``f6 = 3.35 Hz``; with
``f5 = f6`` the step would be unity and W_k would lose its 0.5 gain below 2 Hz.
The digital filter is the bilinear transform of the analog one at the sampling
rate, as second-order sections.
"""

from __future__ import annotations

import numpy as np
from scipy import signal

F1, F2, F3, F4, Q4, F5, Q5, F6, Q6 = 0.4, 100.0, 12.5, 12.5, 0.63, 2.37, 0.91, 3.35, 0.91


def wk_analog() -> tuple[np.ndarray, np.ndarray]:
    """Analog W_k as polynomial coefficients ``(b, a)`` in ``s`` (highest power first)."""
    w1, w2, w3, w4, w5, w6 = (2.0 * np.pi * f for f in (F1, F2, F3, F4, F5, F6))
    sections = [
        ([1.0, 0.0, 0.0], [1.0, np.sqrt(2.0) * w1, w1**2]),
        ([w2**2], [1.0, np.sqrt(2.0) * w2, w2**2]),
        ([1.0 / w3, 1.0], [1.0 / w4**2, 1.0 / (Q4 * w4), 1.0]),
        ([1.0, w5 / Q5, w5**2], [1.0, w6 / Q6, w6**2]),
    ]
    b = np.array([1.0])
    a = np.array([1.0])
    for nb, na in sections:
        b = np.polymul(b, nb)
        a = np.polymul(a, na)
    return b, a


def wk_magnitude(f: np.ndarray) -> np.ndarray:
    """``|W_k(j 2 pi f)|`` of the analog weighting at frequencies ``f`` (Hz)."""
    b, a = wk_analog()
    _, h = signal.freqs(b, a, worN=2.0 * np.pi * np.asarray(f, dtype=np.float64))
    return np.abs(h)


def wk_sos(fs: float) -> np.ndarray:
    """Digital W_k (bilinear transform) for sampling rate ``fs`` (Hz) as second-order sections."""
    if not np.isfinite(fs) or fs <= 2.0 * F2:
        raise ValueError(f"fs: sampling rate must be > {2 * F2} Hz (2 f2), got {fs!r}")
    b, a = wk_analog()
    z, p, k = signal.tf2zpk(b, a)
    zd, pd, kd = signal.bilinear_zpk(z, p, k, fs)
    return signal.zpk2sos(zd, pd, kd)


def weighted_rms(acc: np.ndarray, fs: float, settle: float = 0.0) -> float | np.ndarray:
    """ISO 2631-1 frequency-weighted RMS acceleration ``a_w`` (m/s^2).

    Args:
        acc: vertical acceleration, shape ``(T,)`` or ``(n, T)`` (time last), m/s^2.
        fs: sampling rate (Hz).
        settle: seconds discarded at the start (filter transient).
    """
    a = np.asarray(acc, dtype=np.float64)
    if not np.all(np.isfinite(a)):
        raise ValueError("acc: acceleration contains non-finite values")
    aw = signal.sosfilt(wk_sos(fs), a, axis=-1)
    start = int(round(settle * fs))
    if start >= a.shape[-1]:
        raise ValueError(f"settle: {settle} s leaves no samples of the {a.shape[-1] / fs} s record")
    out = np.sqrt(np.mean(aw[..., start:] ** 2, axis=-1))
    return float(out) if out.ndim == 0 else out
