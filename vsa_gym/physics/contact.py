"""Smooth penalty contact for end stops and travel limits.

A stop is violated when ``z > 0`` (``z`` = coordinate beyond the limit).  The
penetration is a softplus of ``z`` so that force, energy and dissipation are
smooth (C-infinity) in the state -- a fixed-step RK4 keeps its order through an
impact and the stiff Radau reference does not stall on a kink::

    pen(z) = eps * log(1 + exp(z / eps))        (-> max(z, 0) for |z| >> eps)
    w(z)   = d pen / dz = 1 / (1 + exp(-z / eps))
    U      = K pen^2 / 2
    f      = K pen w + D w z_dot                  (resisting force along -z)
    P_diss = D w z_dot^2 >= 0

``f`` is exactly ``dU/dz`` plus a dissipative term, so energy balances hold.
The smoothing width ``eps`` is a numerics parameter: the stop acts ``eps`` early.

Far from contact (``z < -FAR eps``) ``w`` is exactly 0.0 in floating point, so force
and dissipation are exactly zero and the stored energy is below ``1e-35 K eps^2``.  The
compiled per-row path takes that shortcut (no ``exp``/``log1p``/``tanh``: a stop is far
from contact almost always): the same force and dissipation bit for bit, and an energy of
0.0 instead of that underflowing remainder (``tests/vsaut2/test_kernels.py``).  The numpy
path always runs the full formula.

Shapes: arguments broadcast to ``(n,)``.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba.extending import register_jitable

from vsa_gym.physics.kernels import scalar_shortcut

#: In units of ``eps``: beyond this distance from the stop ``tanh(z / (2 eps)) == -1.0`` exactly (float64).
FAR = 40.0


class ContactForce(NamedTuple):
    force: np.ndarray  # resisting force along -z (>= 0 while penetrating)
    energy: np.ndarray  # stored penetration energy (J)
    p_diss: np.ndarray  # dissipated power (W)


@register_jitable
def penalty_contact(z: np.ndarray, z_dot: np.ndarray, K: float, D: float, eps: float) -> ContactForce:
    """Smooth one-sided contact (see module docstring)."""
    s = z / eps
    if scalar_shortcut(s < -FAR):  # compiled, one row: the formula below gives these (energy < 1e-35 K eps^2)
        zero = 0.0 * np.abs(z_dot)
        return ContactForce(zero, zero, zero)
    pen = eps * (np.maximum(s, 0.0) + np.log1p(np.exp(-np.abs(s))))
    w = 0.5 * (1.0 + np.tanh(0.5 * s))
    damp = D * w * z_dot
    return ContactForce(K * pen * w + damp, 0.5 * K * pen * pen, damp * z_dot)


@register_jitable
def two_sided_stop(
    q: np.ndarray, q_dot: np.ndarray, lo: float, hi: float, K: float, D: float, eps: float
) -> ContactForce:
    """Stops at ``lo`` and ``hi`` on coordinate ``q``: returns the generalised force on ``q``.

    ``force`` is signed along ``+q`` (negative at the upper stop, positive at the lower).
    """
    up = penalty_contact(q - hi, q_dot, K, D, eps)
    down = penalty_contact(lo - q, -q_dot, K, D, eps)
    return ContactForce(down.force - up.force, up.energy + down.energy, up.p_diss + down.p_diss)
