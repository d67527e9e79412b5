"""Excitation signals of the truth experiments, designed on the *nominal* (datasheet) model.

Open loop, the drive command is the feedforward of a planned position path ``r(t)`` through the
nominal rigid model ``m r'' + b r' = k_u u`` (``m, b, k_u`` as in the sidecar), so that the axis
moves back and forth around its start with the planned amplitude and speeds; the real axis
(friction, gravity, ...) deviates from the plan, as a real one would.  Closed loop, ``r(t)`` is the
reference of the PD loop.  Paths (position in m or rad, relative to the start):

* multisine: ``r = w(t) sum_k a_k sin(2 pi f_k t + phi_k)``, ``f_k`` log-spaced, ``a_k ~ 1/f_k``
  (equal speed per line; ``1/f_k^1.5`` for a current amplifier, whose force goes with the
  acceleration), random phases;
* chirp: ``r = w(t) a(t) sin(2 pi f_0 T (e^{kt} - 1) / ln(f_1/f_0))``, ``k = ln(f_1/f_0)/T``,
  ``a = (A^-4 + (omega/v_peak)^4 + (omega^2/kappa)^4)^(-1/4)``, a smooth minimum of the stroke,
  speed and (current amplifier only: ``kappa = 2 v_peak^2 / A``) acceleration limits;
* sines: 1-3 sines of 0.2-3 Hz;
* moves: point-to-point minimum-jerk moves ``r = r_0 + d (10 s^3 - 15 s^4 + 6 s^5)`` between
  random targets in ``[-A, A]``, with dwells at rest (stiction is visited);
* steps (open loop only): piecewise-constant commands; a voltage drive's level sets a speed
  ``v = k_u u / b``, a current amplifier's a force doublet ``+F, -F`` (a move that ends at rest);
  the sign of the next step points back to the start whenever the planned position is beyond ``0.4 A``.

``w(t)`` is a quintic fade-in over 0.5 s (``w = 10 s^3 - 15 s^4 + 6 s^5``): every path starts at rest.
Each path is scaled so that ``max |r| <= A`` and ``max |r'| <= v_peak``.
"""

from __future__ import annotations

import numpy as np


def fade(t: np.ndarray, t_fade: float = 0.5) -> np.ndarray:
    """Quintic fade-in 0 -> 1 over ``t_fade`` seconds (zero slope and curvature at both ends)."""
    s = np.clip(t / t_fade, 0.0, 1.0)
    return 10 * s**3 - 15 * s**4 + 6 * s**5


def derivative(y: np.ndarray, dt: float) -> np.ndarray:
    """Second-order central difference ``dy/dt`` (one-sided at the ends)."""
    return np.gradient(y, dt, edge_order=2)


def _scale(r: np.ndarray, dt: float, amplitude: float, v_peak: float) -> np.ndarray:
    rmax = float(np.max(np.abs(r))) or 1.0
    vmax = float(np.max(np.abs(derivative(r, dt)))) or 1.0
    return r * min(amplitude / rmax, v_peak / vmax)


def multisine(rng: np.random.Generator, t: np.ndarray, amplitude: float, v_peak: float, f_lo: float, f_hi: float,
              current_mode: bool = False) -> np.ndarray:
    """Faded multisine path (5-12 lines between ``f_lo`` and ``f_hi`` Hz)."""
    n = int(rng.integers(5, 13))
    f = np.geomspace(f_lo, f_hi, n) * rng.uniform(0.95, 1.05, n)
    ph = rng.uniform(0, 2 * np.pi, n)
    a = f ** (-1.5 if current_mode else -1.0)
    r = (a[:, None] * np.sin(2 * np.pi * f[:, None] * t[None, :] + ph[:, None])).sum(0)
    return _scale(fade(t) * r, t[1] - t[0], amplitude, v_peak)


def chirp(rng: np.random.Generator, t: np.ndarray, amplitude: float, v_peak: float, f_lo: float, f_hi: float,
          current_mode: bool = False) -> np.ndarray:
    """Faded exponential chirp from ``f_lo`` to ``f_hi`` Hz with stroke-, speed- (and acceleration-) limited
    amplitude."""
    T = float(t[-1]) or 1.0
    k = np.log(f_hi / f_lo) / T
    phase = 2 * np.pi * f_lo * (np.exp(k * t) - 1) / k + rng.uniform(0, 2 * np.pi)
    w = 2 * np.pi * f_lo * np.exp(k * t)
    kappa = 2 * v_peak**2 / amplitude if current_mode else np.inf
    a = (amplitude**-4 + (w / v_peak) ** 4 + (w**2 / kappa) ** 4) ** -0.25
    return _scale(fade(t) * a * np.sin(phase), t[1] - t[0], amplitude, v_peak)


def sines(rng: np.random.Generator, t: np.ndarray, amplitude: float, v_peak: float) -> np.ndarray:
    """Faded sum of 1-3 sines of 0.2-3 Hz."""
    n = int(rng.integers(1, 4))
    f = rng.uniform(0.2, 3.0, n)
    a = rng.uniform(0.3, 1.0, n)
    ph = rng.uniform(0, 2 * np.pi, n)
    r = (a[:, None] * np.sin(2 * np.pi * f[:, None] * t[None, :] + ph[:, None])).sum(0)
    return _scale(fade(t) * r, t[1] - t[0], amplitude, v_peak)


def moves(rng: np.random.Generator, t: np.ndarray, amplitude: float, v_peak: float) -> np.ndarray:
    """Minimum-jerk point-to-point moves between random targets in ``[-A, A]`` with dwells of 0.05-0.6 s."""
    r = np.zeros_like(t)
    i, pos = int(np.searchsorted(t, rng.uniform(0.1, 0.4))), 0.0
    while i < t.size:
        target = float(rng.uniform(-amplitude, amplitude))
        d = target - pos
        v = rng.uniform(0.3, 1.0) * v_peak
        T = max(1.875 * abs(d) / v, 0.15)
        n = max(int(round(T / (t[1] - t[0]))), 2)
        s = np.linspace(0.0, 1.0, n + 1)[1:]
        seg = pos + d * (10 * s**3 - 15 * s**4 + 6 * s**5)
        m = min(n, t.size - i)
        r[i:i + m] = seg[:m]
        pos = float(seg[m - 1])
        i += m
        dwell = int(round(rng.uniform(0.05, 0.6) / (t[1] - t[0])))
        r[i:i + dwell] = pos
        i += dwell
    return r


def steps(rng: np.random.Generator, t: np.ndarray, amplitude: float, v_peak: float, m: float, b: float,
          k_u: float, current_mode: bool) -> np.ndarray:
    """Piecewise-constant drive command (input units) planned on the nominal model ``m v' = k_u u - b v``."""
    dt = float(t[1] - t[0])
    u = np.zeros_like(t)
    i = int(round(rng.uniform(0.1, 0.3) / dt))
    x_plan = 0.0
    while i < t.size:
        v = rng.uniform(0.3, 1.0) * v_peak
        T = rng.uniform(0.15, 0.8)
        sign = -np.sign(x_plan) if abs(x_plan) > 0.4 * amplitude else rng.choice([-1.0, 1.0])
        n = max(int(round(T / dt)), 2)
        if current_mode:  # force doublet: accelerate to v over T/2, brake to rest over T/2
            F = m * v / (T / 2) + b * v / 2
            h = n // 2
            u[i:i + h] = sign * F / k_u
            u[i + h:i + n] = -sign * F / k_u
            x_plan += sign * v * T / 2
        else:
            u[i:i + n] = sign * b * v / k_u
            x_plan += sign * v * T
        i += n
        rest = int(round(rng.uniform(0.0, 0.4) / dt))
        i += rest
    return u


def feedforward(r: np.ndarray, dt: float, m: float, b: float) -> np.ndarray:
    """Nominal drive force (N or N m) along path ``r``: ``m r'' + b r'``."""
    v = derivative(r, dt)
    return m * derivative(v, dt) + b * v


__all__ = ["chirp", "derivative", "fade", "feedforward", "moves", "multisine", "sines", "steps"]
