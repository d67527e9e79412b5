"""Linearised modes of the vsaUT-II core: the eigenvalues the integrators' sub-steps are chosen against.

    python -m benchmarks.core_modes [Q1_MM ...]        (default: 2 30 40)

At rest with the pivot at ``q1`` (m; :meth:`VsaUT2Model.initial_state`), zero voltages and no external torque,
the Jacobian of :meth:`VsaUT2Model.rhs` by central differences (step 1e-7 relative); prints the three fastest
real poles and the fastest complex pair (1/s) with its frequency.  These are the figures quoted in the
``VsaUT2Model`` docstring and docs/performance.md (current poles -9.0e3 and -3.6e3 1/s, belt/frame mode
-209 +- 3566j 1/s = 568 Hz at q1 = 2 mm).
"""

from __future__ import annotations

import sys

import numpy as np

from vsa_gym.devices.vsaut2.model import VsaUT2Model


def modes(q1: float, model: VsaUT2Model | None = None) -> np.ndarray:
    """Eigenvalues (1/s) of the core's Jacobian at rest with the pivot at ``q1`` (m), sorted by real part."""
    m = VsaUT2Model() if model is None else model
    x0 = m.initial_state(1, q1=q1)[0]
    u = np.zeros(2)
    J = np.empty((x0.size, x0.size))
    for k in range(x0.size):
        h = 1e-7 * max(1.0, abs(x0[k]))
        xp, xm = x0.copy(), x0.copy()
        xp[k] += h
        xm[k] -= h
        J[:, k] = (m.rhs(xp, u, 0.0)[0] - m.rhs(xm, u, 0.0)[0]) / (2.0 * h)
    ev = np.linalg.eigvals(J)
    return ev[np.argsort(ev.real)]


def main(argv: list[str] | None = None) -> None:
    args = sys.argv[1:] if argv is None else argv
    for q1_mm in [float(a) for a in args] or [2.0, 30.0, 40.0]:
        ev = modes(q1_mm * 1e-3)
        cplx = ev[ev.imag > 1.0]
        pair = cplx[np.argmax(cplx.imag)] if cplx.size else None
        real = ", ".join(f"{v:.3g}" for v in ev.real[:3])
        mode = "-" if pair is None else f"{pair.real:.0f} +- {pair.imag:.0f}j 1/s ({pair.imag / (2 * np.pi):.0f} Hz)"
        print(f"q1 = {q1_mm:g} mm: fastest real poles {real} 1/s; fastest mode {mode}")


if __name__ == "__main__":
    main()
