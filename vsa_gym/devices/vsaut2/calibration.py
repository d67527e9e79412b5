"""How the lever length ``l`` is chosen (it is not published).

``K = 2 k l^2 ((l - q1)/q1)^2`` depends on ``l`` only through ``l rho``, so ``l``
fixes where on the pivot stroke the minimum stiffness ``K_min = 0.7 N m/rad``
lies: ``q1_max(l) = l^2 / (l + sqrt(K_min / 2k))``.  The pivot drive takes longer
to cover a longer stroke, so ``l`` is calibrated on Table IV row 4: the no-load
stiffness variation time, minimum -> maximum stiffness at full voltage, is 0.78 s.

Protocol (:func:`stiffness_variation_time`): the pivot starts at rest at the soft
end ``q1_max``; the pivot motor gets -24 V; the time is taken when ``q1`` reaches
the stiff end ``q1 = 0``.  The frame drive is unpowered and the output undeflected,
so the springs exert no pivot force (``F_q1 = 0`` at ``phi = 0``).

Running :func:`calibrate_lever_length` gives l = 0.0620 m, the value stored in
:class:`vsa_gym.devices.vsaut2.lever.LeverParams` (the test suite re-runs the protocol).
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import brentq

from vsa_gym.devices.vsaut2.model import VsaUT2Model
from vsa_gym.devices.vsaut2.params import VsaUT2Params

TARGET_TIME_S = 0.78  # Table IV row 4


def stiffness_variation_time(
    params: VsaUT2Params, tau_load: float = 0.0, t_max: float = 2.0, dt: float = 1e-3
) -> np.ndarray:
    """Time (s) to drive the pivot from minimum to maximum stiffness at full voltage.

    ``tau_load`` (N m) is a constant torque on the output (0 for the no-load row,
    the nominal torque for row 5); the frame is then held by its motor's gearbox at
    standstill (short-circuited motor, ``u2 = 0``) and the output settles against the
    springs before the pivot starts.  Batched: returns shape ``(n,)`` for a batch of
    ``n`` parameter sets (``nan`` where the stiff end is not reached within ``t_max``).
    """
    model = VsaUT2Model(params)
    n = params.batch_size or 1
    x = model.initial_state(n, q1=params.q1_max)
    tau = np.full(n, tau_load)
    if tau_load != 0.0:
        # let the output settle against the springs at the soft end before starting the clock
        for _ in range(int(1.5 / dt)):
            x, _ = model.step(x, np.zeros((n, 2)), tau, dt)
    u = np.zeros((n, 2))
    u[:, 0] = -params.pivot_motor.U_max
    times = np.full(n, np.nan)
    th_prev = x[:, 1].copy()
    for k in range(int(t_max / dt)):
        x, _ = model.step(x, u, tau, dt)
        crossed = np.isnan(times) & (x[:, 1] <= 0.0)
        if np.any(crossed):
            # linear interpolation of the crossing inside the step
            frac = th_prev[crossed] / (th_prev[crossed] - x[crossed, 1])
            times[crossed] = (k + frac) * dt
        th_prev = x[:, 1].copy()
        if not np.any(np.isnan(times)):
            break
    return times


def calibrate_lever_length(target: float = TARGET_TIME_S, bracket: tuple[float, float] = (0.060, 0.103)) -> float:
    """Lever length (m) whose no-load stiffness variation time equals ``target``."""
    base = VsaUT2Params()
    grid = np.linspace(*bracket, 12)
    params = VsaUT2Params.stack([base.replace(lever=base.lever.replace(l=float(v))) for v in grid])
    times = stiffness_variation_time(params, t_max=3.0)
    ok = np.isfinite(times)
    f = np.interp  # monotone in l: longer lever -> longer stroke
    l0 = float(f(target, times[ok], grid[ok]))

    def err(l: float) -> float:
        p = base.replace(lever=base.lever.replace(l=l))
        return float(stiffness_variation_time(p)[0]) - target

    lo, hi = max(bracket[0], l0 - 0.004), min(bracket[1], l0 + 0.004)
    return float(brentq(err, lo, hi, xtol=1e-5))
