"""Static experiments on the vsaUT-II model: equilibria of the same right-hand side.

The torque-deflection protocol of Sec. IV (Fig. 11) is quasi-static: a force is
applied at the output while the frame drive holds its motor, and the deflection
is read.  :func:`output_equilibrium` finds that equilibrium by driving the
accelerations of the frame and the output computed by :meth:`VsaUT2Model.rhs` to
zero (frame motor angle fixed, currents and velocities zero), so the result
includes the belt in series exactly as the dynamic model has it.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import root

from vsa_gym.devices.vsaut2.model import STATE, VsaUT2Model


def output_equilibrium(model: VsaUT2Model, q1: float, tau_ext: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Frame angle and output angle at static equilibrium under output torques ``tau_ext``.

    The frame motor is locked at the angle that leaves the belt unstretched at
    ``q2 = 0``; the pivot is at ``q1`` (m).  Returns ``(q2, r)`` arrays (rad) with the
    shape of ``tau_ext``; continuation from small to large torques keeps the solver
    on the physical branch.
    """
    tau_ext = np.atleast_1d(np.asarray(tau_ext, dtype=np.float64))
    x = model.initial_state(1, q1=q1)
    u = np.zeros((1, 2))
    order = np.argsort(np.abs(tau_ext))
    q2_out = np.empty_like(tau_ext)
    r_out = np.empty_like(tau_ext)
    guess_pos = np.zeros(2)
    guess_neg = np.zeros(2)
    for idx in order:
        tau = tau_ext[idx]

        def residual(z: np.ndarray, tau: float = tau) -> np.ndarray:
            xx = x.copy()
            xx[0, STATE["q2"]] = z[0]
            xx[0, STATE["r"]] = z[1]
            dx, _ = model.rhs(xx, u, np.array([tau]))
            return np.array([dx[0, STATE["q2_dot"]] * model.params.I_ad, dx[0, STATE["r_dot"]] * model.params.I_o])

        guess = guess_pos if tau >= 0 else guess_neg
        sol = root(residual, guess, method="hybr", tol=1e-12)
        if not sol.success or np.max(np.abs(residual(sol.x))) > 1e-8:
            sol = root(residual, guess, method="lm", tol=1e-14)
        if np.max(np.abs(residual(sol.x))) > 1e-8:
            q2_out[idx] = r_out[idx] = np.nan
            continue
        q2_out[idx], r_out[idx] = sol.x
        if tau >= 0:
            guess_pos = sol.x
        else:
            guess_neg = sol.x
    return q2_out, r_out


def static_output_stiffness(model: VsaUT2Model, q1: float, d_tau: float = 1e-3) -> float:
    """Output stiffness (N m/rad) from a central finite difference of equilibrium deflections."""
    _, r = output_equilibrium(model, q1, np.array([-d_tau, d_tau]))
    return float(2 * d_tau / (r[1] - r[0]))
