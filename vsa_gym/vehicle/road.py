"""ISO 8608 random road profiles, reproducible from a seed.

Displacement PSD of class ``c`` (ISO 8608, class geometric means)::

    G_d(n) = G_d(n0) (n / n0)^-2,   n0 = 0.1 cycles/m,
    G_d(n0) = 16e-6 m^3 * 4^k  for classes A, B, ..., H (k = 0 .. 7)

The profile is synthesised in the frequency domain: a sum of cosines on the
FFT grid ``n_k = k / (N dx)`` inside the band ``[n_min, n_max]`` (default
0.011 .. 2.83 cycles/m, the ISO 8608 band), amplitudes ``sqrt(2 G_d(n_k) dn)``
and phases uniform from ``numpy.random.default_rng(seed)``.  Its one-sided PSD
is therefore ``G_d`` on every grid frequency of the band.  A vehicle at speed
``v`` sees the height ``h(v t)`` (linear interpolation).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

ROAD_CLASSES = "ABCDEFGH"
N0 = 0.1  # reference spatial frequency (cycles/m)
GD_A = 16e-6  # G_d(n0) of class A (m^3)
N_MIN = 0.011  # ISO 8608 band (cycles/m)
N_MAX = 2.83


class RoadProfile(NamedTuple):
    """A road: positions ``x`` (m, from 0, spacing ``dx``) and heights ``h`` (m), shape ``(N,)``."""

    x: np.ndarray
    h: np.ndarray
    road_class: str
    seed: int


def class_gd_n0(road_class: str) -> float:
    """``G_d(n0)`` (m^3) of an ISO 8608 class ``'A'`` .. ``'H'``."""
    if not isinstance(road_class, str) or road_class.upper() not in ROAD_CLASSES or len(road_class) != 1:
        raise ValueError(f"road_class: must be one of {', '.join(ROAD_CLASSES)}, got {road_class!r}")
    return GD_A * 4.0 ** ROAD_CLASSES.index(road_class.upper())


def iso8608_psd(n: np.ndarray, road_class: str) -> np.ndarray:
    """One-sided displacement PSD ``G_d(n)`` (m^3) at spatial frequencies ``n`` (cycles/m, > 0)."""
    n = np.asarray(n, dtype=np.float64)
    if np.any(n <= 0.0) or not np.all(np.isfinite(n)):
        raise ValueError("n: spatial frequencies must be finite and > 0 cycles/m")
    return class_gd_n0(road_class) * (n / N0) ** -2


def generate_profile(road_class: str, length: float, seed: int, dx: float = 0.05,
                     n_min: float = N_MIN, n_max: float = N_MAX) -> RoadProfile:
    """A random ISO 8608 profile of ``length`` m sampled every ``dx`` m.

    Raises ``ValueError`` for a bad class, a non-positive length/spacing, a band
    outside ``(0, 1/(2 dx))`` or a road too short to contain ``n_min``.
    """
    gd0 = class_gd_n0(road_class)
    for name, v in (("length", length), ("dx", dx), ("n_min", n_min), ("n_max", n_max)):
        if not np.isfinite(v) or v <= 0.0:
            raise ValueError(f"{name}: must be finite and > 0, got {v!r}")
    if n_max > 0.5 / dx:
        raise ValueError(f"n_max: {n_max} cycles/m is above the Nyquist frequency 1/(2 dx) = {0.5 / dx}")
    if n_min >= n_max:
        raise ValueError(f"n_min: must be < n_max ({n_max}), got {n_min}")
    N = int(np.ceil(length / dx))
    N += N % 2
    dn = 1.0 / (N * dx)
    if n_min < dn:
        raise ValueError(f"length: {length} m is too short to resolve n_min = {n_min} cycles/m")
    rng = np.random.default_rng(seed)
    k = np.arange(N // 2 + 1)
    n = k * dn
    band = (n >= n_min) & (n <= n_max)
    amp = np.zeros(n.shape)
    amp[band] = np.sqrt(2.0 * gd0 * (n[band] / N0) ** -2 * dn)
    phase = rng.uniform(0.0, 2.0 * np.pi, size=n.shape)
    spectrum = 0.5 * N * amp * np.exp(1j * phase)
    h = np.fft.irfft(spectrum, n=N)
    return RoadProfile(np.arange(N) * dx, h, road_class.upper(), int(seed))


def time_signal(profile: RoadProfile, speed: float, dt: float, n_steps: int, x0: float = 0.0) -> np.ndarray:
    """Heights under the tyre at ``t_k = k dt``, ``k = 0 .. n_steps`` (shape ``(n_steps + 1,)``).

    Raises ``ValueError`` for a negative or non-finite speed, a non-positive ``dt``
    or a drive past the end of the profile.
    """
    if not np.isfinite(speed) or speed < 0.0:
        raise ValueError(f"speed: must be finite and >= 0 m/s, got {speed!r}")
    if not np.isfinite(dt) or dt <= 0.0:
        raise ValueError(f"dt: must be > 0 s, got {dt!r}")
    pos = x0 + speed * dt * np.arange(n_steps + 1)
    if pos[-1] > profile.x[-1]:
        raise ValueError(f"speed: driving {pos[-1]:.1f} m passes the end of the {profile.x[-1]:.1f} m profile")
    return np.interp(pos, profile.x, profile.h)


def road_signal(road_class: str, speed: float, duration: float, dt: float, seed: int) -> np.ndarray:
    """Convenience: a fresh profile long enough for ``duration`` s at ``speed``, sampled every ``dt``.

    The profile is at least 1 km long (so the ISO band's low end is resolved) and
    starts from a 0.5 s ramp-in (heights multiplied by ``t / 0.5``) so that a
    vehicle at static equilibrium on height 0 starts without a jump.
    """
    if not np.isfinite(speed) or speed < 0.0:
        raise ValueError(f"speed: must be finite and >= 0 m/s, got {speed!r}")
    n_steps = int(round(duration / dt))
    length = max(1000.0, speed * duration + 10.0)
    prof = generate_profile(road_class, length, seed)
    h = time_signal(prof, speed, dt, n_steps)
    t = dt * np.arange(n_steps + 1)
    return h * np.minimum(t / 0.5, 1.0)
