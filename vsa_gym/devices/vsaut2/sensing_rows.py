"""The vsaUT-II environments' compiled per-step sensing, observation channels and constraint margins.

Element by element, with the operations of the numpy expressions they replace (sensors.IncrementalEncoder /
AbsoluteEncoder.measure, sensing.update_velocity and i2t_update, eqs. 5 and 6): the values are unchanged
(tests/envs checks them against the sensor objects); one call replaces about 40 small numpy calls per step.
:mod:`vsa_gym.devices.vsaut2.task` calls them from its compiled step and at reset.
"""

from __future__ import annotations

import numba
import numpy as np
from numba.extending import register_jitable

from vsa_gym.devices.vsaut2.belt import series_stiffness
from vsa_gym.devices.vsaut2.lever import spring_stiffness
from vsa_gym.devices.vsaut2.model import P_ROW, STATE
from vsa_gym.devices.vsaut2.pivot import pivot_position
from vsa_gym.envs.sensing import i2t_update, update_velocity
from vsa_gym.physics.sensors import absolute_encoder_angle, floor_quantize

K_FLOOR = 0.1  # N m/rad, floor of the stiffness before taking its log (eq. 6 turns negative past 45 deg)
N_COMMON_OBS = 11  # channels of VsaUT2Task._common_channels (the tasks append theirs after these)

# eq. (6) of the lever and the sensing updates of sensing.py, made callable from the compiled sensing (the same
# functions, not a copy)
register_jitable(spring_stiffness)
register_jitable(series_stiffness)
register_jitable(update_velocity)
register_jitable(i2t_update)
# state columns (STATE) as constants the compiled sensing can fold
_I1, _TH1, _I2, _TH2, _Q2, _R = STATE["i1"], STATE["th1"], STATE["i2"], STATE["th2"], STATE["q2"], STATE["r"]



@numba.njit(cache=True)
def sense_update(x: np.ndarray, meas: np.ndarray, vel: np.ndarray, i2t: np.ndarray, enc: np.ndarray, dt: float,
                  gain: float, i_nom: float) -> None:
    """In place, every row: I^2 t states ``(n, 2)``, quantised angles ``meas`` and speed estimates ``vel`` ``(n, 3)``.

    ``enc = [motor encoder step, output encoder step, output gain mismatch]`` (step 0: exact angle).
    """
    for i in range(x.shape[0]):
        for j, col in ((0, _I1), (1, _I2)):
            i2t[i, j] = i2t_update(i2t[i, j], x[i, col] ** 2, i_nom, dt)
        m = np.empty(3)
        for j, col in ((0, _TH1), (1, _TH2)):
            m[j] = floor_quantize(x[i, col], enc[0])
        m[2] = absolute_encoder_angle(x[i, _R], enc[1], enc[2])
        for j in range(3):
            vel[i, j] = update_velocity(meas[i, j], m[j], vel[i, j], dt, gain)
            meas[i, j] = m[j]


@numba.njit(cache=True)
def common_obs_rows(meas: np.ndarray, vel: np.ndarray, cur: np.ndarray, i2t: np.ndarray, i2t_lim: np.ndarray,
                     P: np.ndarray, K_b: np.ndarray, ratio: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """The common observation channels of ``rows``, ``(len(rows), N_COMMON_OBS)`` (see ``_common_channels``)."""
    out = np.empty((rows.shape[0], N_COMMON_OBS))
    for j in range(rows.shape[0]):
        common_obs_row(meas, vel, cur, i2t, i2t_lim, P, K_b, ratio, rows[j], out[j])
    return out


@register_jitable
def common_obs_row(meas: np.ndarray, vel: np.ndarray, cur: np.ndarray, i2t: np.ndarray, i2t_lim: np.ndarray,
                    P: np.ndarray, K_b: np.ndarray, ratio: np.ndarray, i: int, o: np.ndarray) -> None:
    """Row ``i`` of :func:`common_obs_rows` into ``o[:N_COMMON_OBS]``."""
    p = P_ROW(P, i)
    q1 = pivot_position(p.pivot, meas[i, 0] / p.pivot_gearbox.n)
    q2 = meas[i, 1] / ratio[i]
    K_s = spring_stiffness(p.lever, q1, meas[i, 2] - q2)
    K = max(series_stiffness(K_s, K_b[i]), K_FLOOR) if K_s > 0 else K_FLOOR
    o[0], o[1], o[2] = q1, q2, meas[i, 2]
    o[3], o[4], o[5] = vel[i, 0], vel[i, 1], vel[i, 2]
    o[6], o[7], o[8] = cur[i, 0], cur[i, 1], np.log(K)
    o[9] = min(i2t[i, 0] / i2t_lim[i, 0], 1.0)
    o[10] = min(i2t[i, 1] / i2t_lim[i, 1], 1.0)


@numba.njit(cache=True)
def true_stiffness(x: np.ndarray, P: np.ndarray, K_b: np.ndarray) -> np.ndarray:
    """``VsaUT2Model.stiffness(x)``: eq. (6) at the true pivot and deflection in series with the belt, ``(n,)``."""
    out = np.empty(x.shape[0])
    for i in range(x.shape[0]):
        out[i] = true_stiffness_row(x, P, K_b, i)
    return out


@register_jitable
def true_stiffness_row(x: np.ndarray, P: np.ndarray, K_b: np.ndarray, i: int) -> float:
    """Row ``i`` of :func:`true_stiffness`."""
    p = P_ROW(P, i)
    K_s = spring_stiffness(p.lever, pivot_position(p.pivot, x[i, _TH1] / p.pivot_gearbox.n), x[i, _R] - x[i, _Q2])
    return series_stiffness(K_s, K_b[i])


@numba.njit(cache=True)
def margin_rows(x: np.ndarray, i2t: np.ndarray, th1_max: np.ndarray, q2_max: np.ndarray, phi_max: np.ndarray,
                 lim: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """Constraint margins of ``rows``, ``(len(rows), 4)``: frame stop, deflection stop, I^2 t, pivot stroke."""
    out = np.empty((rows.shape[0], 4))
    for j in range(rows.shape[0]):
        out[j, 0], out[j, 1], out[j, 2], out[j, 3] = margin_row(x, i2t, th1_max, q2_max, phi_max, lim, rows[j])
    return out


@register_jitable
def margin_row(x: np.ndarray, i2t: np.ndarray, th1_max: np.ndarray, q2_max: np.ndarray, phi_max: np.ndarray,
                lim: np.ndarray, i: int) -> tuple[float, float, float, float]:
    """Row ``i`` of :func:`margin_rows`."""
    q2, th1 = x[i, _Q2], x[i, _TH1]
    return (q2_max[i] - abs(q2), phi_max[i] - abs(x[i, _R] - q2),
            min(1.0 - i2t[i, 0] / lim[i, 0], 1.0 - i2t[i, 1] / lim[i, 1]), min(th1, th1_max[i] - th1) / th1_max[i])
