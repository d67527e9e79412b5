"""Batched reference and excitation signals with per-row random streams.

* :class:`SegmentReference` -- a chain of random segments (step, ramp, sine) inside
  ``[low, high]``, each lasting a random time; a new segment starts from the
  current value, so ramps and sines are continuous and steps jump.  Used for the
  position, stiffness, force and disturbance references.
* :class:`Multisine` -- a sum of sines with random phases: a few dominant sines
  plus "filtered noise" synthesised as many log-spaced components whose
  amplitudes follow a first-order low-pass spectrum (the random-phase multisine
  representation of filtered noise).  The amplitudes are scaled so that the sum
  of their magnitudes equals the peak, so ``|signal| <= peak`` holds exactly.
  Used for the rig's imposed wishbone angle alpha(t).

State lives in the task's state dict ``s`` under a key prefix (so the vector
environment can snapshot rows); the objects here only hold the configuration.
"""

from __future__ import annotations

from collections.abc import Sequence

import numba
import numpy as np
from numba.extending import register_jitable

STEP, RAMP, SINE = 0, 1, 2
KIND_NAMES = ("step", "ramp", "sine")


class SegmentReference:
    """Random steps, ramps and sines in ``[low, high]`` (see the module docstring)."""

    def __init__(self, prefix: str, low: float, high: float, duration: tuple[float, float] = (0.5, 2.0),
                 freq: tuple[float, float] = (0.2, 2.0), kinds: Sequence[str] = KIND_NAMES,
                 zero_prob: float = 0.0) -> None:
        if not high > low:
            raise ValueError(f"{prefix}: reference range needs high > low, got [{low}, {high}]")
        unknown = set(kinds) - set(KIND_NAMES)
        if unknown or not kinds:
            raise ValueError(f"{prefix}: kinds must be a non-empty subset of {KIND_NAMES}, got {kinds!r}")
        self.prefix, self.low, self.high = prefix, float(low), float(high)
        self.duration, self.freq = duration, freq
        self.kinds = np.array([KIND_NAMES.index(k) for k in kinds])
        self.zero_prob = zero_prob  # probability that a step segment holds 0 (for disturbances)
        self._keys = tuple(f"{prefix}_{name}" for name in ("kind", "t0", "T", "v0", "v1", "A", "f"))

    def alloc(self, s: dict[str, np.ndarray], n: int) -> None:
        for name in ("kind", "t0", "T", "v0", "v1", "A", "f"):
            s[f"{self.prefix}_{name}"] = np.zeros(n)

    def start(self, s: dict[str, np.ndarray], rows: np.ndarray, rngs: list[np.random.Generator],
              t: np.ndarray, v_now: np.ndarray) -> None:
        """Draw a new segment for ``rows`` starting at times ``t`` from values ``v_now``."""
        p = self.prefix
        for j, i in enumerate(rows):
            rng = rngs[int(i)]
            kind = int(self.kinds[rng.integers(len(self.kinds))])
            v0 = float(np.clip(v_now[j], self.low, self.high))
            T = float(rng.uniform(*self.duration))
            v1 = float(rng.uniform(self.low, self.high))
            if self.zero_prob > 0.0 and rng.uniform() < self.zero_prob:
                kind, v1 = STEP, float(np.clip(0.0, self.low, self.high))
            room = min(v0 - self.low, self.high - v0)
            A = float(rng.uniform(0.0, 1.0)) * room * (1.0 if rng.uniform() < 0.5 else -1.0)
            f = float(rng.uniform(*self.freq))
            for name, val in (("kind", kind), ("t0", t[j]), ("T", T), ("v0", v0), ("v1", v1), ("A", A), ("f", f)):
                s[f"{p}_{name}"][i] = val

    def reset(self, s: dict[str, np.ndarray], rows: np.ndarray, rngs: list[np.random.Generator]) -> None:
        """Start at time 0 from a random value."""
        v = np.array([rngs[int(i)].uniform(self.low, self.high) for i in rows])
        self.start(s, rows, rngs, np.zeros(len(rows)), v)

    def _cols(self, s: dict[str, np.ndarray], rows: np.ndarray | slice) -> tuple[np.ndarray, ...]:
        if isinstance(rows, slice):
            return tuple(s[k] for k in self._keys)
        return tuple(s[k][rows] for k in self._keys)

    def value(self, s: dict[str, np.ndarray], t: np.ndarray, rows: np.ndarray | slice = slice(None)) -> np.ndarray:
        """Value of the current segments of ``rows`` at times ``t`` (compiled; one call, no temporaries)."""
        cols = self._cols(s, rows)
        t = np.asarray(t, dtype=np.float64)
        if t.shape != cols[0].shape:
            t = np.ascontiguousarray(np.broadcast_to(t, cols[0].shape))
        return _segment_values(*cols, t)[0]

    def advance(self, s: dict[str, np.ndarray], t: np.ndarray, rngs: list[np.random.Generator]) -> np.ndarray:
        """Value at times ``t`` (all rows), renewing the segments that have ended."""
        v, ended_mask, n_ended = _segment_values(*self._cols(s, slice(None)), np.asarray(t, dtype=np.float64))
        if n_ended:
            self.renew(s, np.flatnonzero(ended_mask), rngs, t, v)
        return v

    def renew(self, s: dict[str, np.ndarray], ended: np.ndarray, rngs: list[np.random.Generator], t: np.ndarray,
              v: np.ndarray) -> None:
        """Start new segments in the ``ended`` rows at times ``t[ended]`` from ``v[ended]`` (all rows' values at
        ``t``), and put the new segments' values at ``t`` into ``v`` (in place)."""
        self.start(s, ended, rngs, t[ended], v[ended])
        v[ended] = self.value(s, t[ended], ended)


@numba.njit(cache=True)
def _segment_values(kind: np.ndarray, t0: np.ndarray, T: np.ndarray, v0: np.ndarray, v1: np.ndarray,
                    A: np.ndarray, f: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
    """Segment values at ``t`` and which segments have ended (``t >= t0 + T``); all ``(n,)``.

    Per element, with ``tau = t - t0``: step ``v1``; ramp ``v0 + (v1 - v0) clip(tau / T, 0, 1)``;
    sine ``v0 + A sin(2 pi f tau)`` -- the same operations in the same order as the former numpy
    expression, so the values are unchanged.
    """
    n = t.shape[0]
    out = np.empty(n)
    ended = np.empty(n, dtype=np.bool_)
    n_ended = 0
    for i in range(n):
        out[i], ended[i] = segment_value(kind, t0, T, v0, v1, A, f, t[i], i)
        n_ended += ended[i]
    return out, ended, n_ended


@register_jitable
def segment_value(kind: np.ndarray, t0: np.ndarray, T: np.ndarray, v0: np.ndarray, v1: np.ndarray, A: np.ndarray,
                   f: np.ndarray, t: float, i: int) -> tuple[float, bool]:
    """Row ``i`` of :func:`_segment_values` at time ``t``: ``(value, ended)``."""
    tau = t - t0[i]
    if kind[i] == STEP:
        v = v1[i]
    elif kind[i] == RAMP:
        v = v0[i] + (v1[i] - v0[i]) * min(max(tau / T[i], 0.0), 1.0)
    else:
        v = v0[i] + A[i] * np.sin(2.0 * np.pi * f[i] * tau)
    return v, t >= t0[i] + T[i]


class Multisine:
    """Random-phase multisine bounded by ``peak`` (see the module docstring)."""

    def __init__(self, prefix: str, peak: float, n_sines: int = 3, sine_freq: tuple[float, float] = (0.1, 3.0),
                 n_noise: int = 24, noise_band: tuple[float, float] = (0.1, 20.0), noise_cutoff: float = 2.0,
                 noise_share: float = 0.4) -> None:
        self.prefix, self.peak = prefix, float(peak)
        self.n_sines, self.sine_freq = n_sines, sine_freq
        self.noise_f = np.geomspace(noise_band[0], noise_band[1], n_noise)
        self.noise_shape = 1.0 / np.sqrt(1.0 + (self.noise_f / noise_cutoff) ** 2)
        self.noise_share = noise_share
        self.k = n_sines + n_noise

    def alloc(self, s: dict[str, np.ndarray], n: int) -> None:
        # w = 2 pi f and sin(phi) are cached at reset (same values as computing them every step)
        for name in ("A", "f", "phi", "w", "sphi"):
            s[f"{self.prefix}_{name}"] = np.zeros((n, self.k))

    def reset(self, s: dict[str, np.ndarray], rows: np.ndarray, rngs: list[np.random.Generator]) -> None:
        p = self.prefix
        for i in rows:
            rng = rngs[int(i)]
            level = float(rng.uniform(0.2, 1.0)) * self.peak  # overall excitation level of this episode
            a_s = rng.uniform(0.0, 1.0, self.n_sines)
            f_s = rng.uniform(*self.sine_freq, self.n_sines)
            a_n = self.noise_shape * rng.uniform(0.5, 1.0, self.noise_f.size)
            a_s = a_s / max(a_s.sum(), 1e-12) * (1.0 - self.noise_share)
            a_n = a_n / a_n.sum() * self.noise_share
            s[f"{p}_A"][i] = level * np.concatenate([a_s, a_n])
            s[f"{p}_f"][i] = np.concatenate([f_s, self.noise_f])
            s[f"{p}_phi"][i] = rng.uniform(0.0, 2.0 * np.pi, self.k)
        s[f"{p}_w"][rows] = 2.0 * np.pi * s[f"{p}_f"][rows]
        s[f"{p}_sphi"][rows] = np.sin(s[f"{p}_phi"][rows])

    def value(self, s: dict[str, np.ndarray], t: np.ndarray, rows: np.ndarray | slice = slice(None)) -> np.ndarray:
        """Signal at times ``t``, starting from 0 at ``t = 0`` (the value at 0 is subtracted; compiled, one call)."""
        p = self.prefix
        A, w, phi, sphi = s[f"{p}_A"][rows], s[f"{p}_w"][rows], s[f"{p}_phi"][rows], s[f"{p}_sphi"][rows]
        t = np.asarray(t, dtype=np.float64)
        if t.shape != (A.shape[0],):
            t = np.ascontiguousarray(np.broadcast_to(t, (A.shape[0],)))
        return _multisine_values(A, w, phi, sphi, t)


@numba.njit(cache=True)
def _multisine_values(A: np.ndarray, w: np.ndarray, phi: np.ndarray, sphi: np.ndarray, t: np.ndarray) -> np.ndarray:
    """``0.5 sum_k A (sin(w t + phi) - sin(phi))`` per row: ``sin(w t + phi) - sin(phi)`` starts at zero; the
    bound doubles, so the amplitudes are halved.

    The sum is numpy's pairwise summation for fewer than 128 terms (eight partial sums, combined pairwise,
    then the remainder), so the values equal the numpy expression's ``np.sum(..., axis=-1)`` term by term.
    """
    out = np.empty(A.shape[0])
    for i in range(A.shape[0]):
        out[i] = multisine_value(A, w, phi, sphi, t[i], i)
    return out


@register_jitable
def multisine_value(A: np.ndarray, w: np.ndarray, phi: np.ndarray, sphi: np.ndarray, tt: float, i: int) -> float:
    """Row ``i`` of :func:`_multisine_values` at time ``tt``."""
    k = A.shape[1]
    if k < 8:
        acc = 0.0
        for j in range(k):
            acc += A[i, j] * (np.sin(w[i, j] * tt + phi[i, j]) - sphi[i, j])
    else:
        r0 = A[i, 0] * (np.sin(w[i, 0] * tt + phi[i, 0]) - sphi[i, 0])
        r1 = A[i, 1] * (np.sin(w[i, 1] * tt + phi[i, 1]) - sphi[i, 1])
        r2 = A[i, 2] * (np.sin(w[i, 2] * tt + phi[i, 2]) - sphi[i, 2])
        r3 = A[i, 3] * (np.sin(w[i, 3] * tt + phi[i, 3]) - sphi[i, 3])
        r4 = A[i, 4] * (np.sin(w[i, 4] * tt + phi[i, 4]) - sphi[i, 4])
        r5 = A[i, 5] * (np.sin(w[i, 5] * tt + phi[i, 5]) - sphi[i, 5])
        r6 = A[i, 6] * (np.sin(w[i, 6] * tt + phi[i, 6]) - sphi[i, 6])
        r7 = A[i, 7] * (np.sin(w[i, 7] * tt + phi[i, 7]) - sphi[i, 7])
        j = 8
        while j <= k - 8:
            r0 += A[i, j] * (np.sin(w[i, j] * tt + phi[i, j]) - sphi[i, j])
            r1 += A[i, j + 1] * (np.sin(w[i, j + 1] * tt + phi[i, j + 1]) - sphi[i, j + 1])
            r2 += A[i, j + 2] * (np.sin(w[i, j + 2] * tt + phi[i, j + 2]) - sphi[i, j + 2])
            r3 += A[i, j + 3] * (np.sin(w[i, j + 3] * tt + phi[i, j + 3]) - sphi[i, j + 3])
            r4 += A[i, j + 4] * (np.sin(w[i, j + 4] * tt + phi[i, j + 4]) - sphi[i, j + 4])
            r5 += A[i, j + 5] * (np.sin(w[i, j + 5] * tt + phi[i, j + 5]) - sphi[i, j + 5])
            r6 += A[i, j + 6] * (np.sin(w[i, j + 6] * tt + phi[i, j + 6]) - sphi[i, j + 6])
            r7 += A[i, j + 7] * (np.sin(w[i, j + 7] * tt + phi[i, j + 7]) - sphi[i, j + 7])
            j += 8
        acc = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
        while j < k:
            acc += A[i, j] * (np.sin(w[i, j] * tt + phi[i, j]) - sphi[i, j])
            j += 1
    return 0.5 * acc
