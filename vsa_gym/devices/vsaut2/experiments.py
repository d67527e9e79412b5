"""The paper's experiments, run on the model (used by ``reproduce``, ``datasheet`` and the tests).

Each function returns plain arrays / numbers; plotting lives in :mod:`vsa_gym.devices.vsaut2.reproduce`.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from vsa_gym.devices.vsaut2.lever import spring_stiffness
from vsa_gym.devices.vsaut2.model import STATE, VsaUT2Model
from vsa_gym.devices.vsaut2.statics import output_equilibrium, static_output_stiffness
from vsa_gym.physics.dc_motor import current_control_voltage
from vsa_gym.physics.gearbox import GearboxParams, efficiency, static_output_torque

#: Pivot positions of Fig. 11 (m).
FIG11_Q1 = (0.020, 0.015, 0.012, 0.0068, 0.0)


def fig8_efficiency(gb: GearboxParams, n_points: int = 200) -> tuple[np.ndarray, np.ndarray]:
    """Efficiency against input torque when driving an inertial load (Fig. 8 protocol).

    Returns ``(tau_in, eta)``: input torques up to the one giving the rated output
    torque x 1.5, and the resulting ``tau_out / (n tau_in)``.
    """
    tau_in_rated = gb.tau_max / (gb.n * float(efficiency(gb, np.array(gb.tau_max))))
    tau_in = np.linspace(1e-5, 1.5 * tau_in_rated, n_points)
    tau_out = static_output_torque(gb, tau_in)
    return tau_in, tau_out / (gb.n * tau_in)


class Trace(NamedTuple):
    t: np.ndarray
    x: np.ndarray  # (T, n_states)
    current: np.ndarray  # frame motor current (A)


def fig9_q2_response(model: VsaUT2Model, i_ref: float = 0.5, t_on: float = 0.5, t_end: float = 1.0,
                     q2_0: float = -0.4) -> Trace:
    """Frame response to a constant frame-motor current for ``t_on`` s from ``q2_0`` (Fig. 9).

    The amplifier runs in current mode (:func:`current_control_voltage`, 1 kHz loop
    bandwidth) at the 10 kHz sub-step rate; after ``t_on`` the current reference is 0.
    The pivot sits at the stiff end and the output is undeflected.
    """
    dt = 1e-4
    x = model.initial_state(1, q1=0.0, q2=q2_0)
    n_steps = int(round(t_end / dt))
    xs = np.empty((n_steps + 1, x.shape[1]))
    xs[0] = x[0]
    motor = model.params.frame_motor
    u = np.zeros((1, 2))
    tau = np.zeros(1)
    for k in range(n_steps):
        ref = i_ref if k * dt < t_on else 0.0
        u[0, 1] = current_control_voltage(motor, ref, x[0, STATE["i2"]], x[0, STATE["w2"]])
        x, _ = model.step(x, u, tau, dt, n_sub=1)
        xs[k + 1] = x[0]
    return Trace(np.arange(n_steps + 1) * dt, xs, xs[:, STATE["i2"]])


class Oscillation(NamedTuple):
    t: np.ndarray
    r: np.ndarray
    peak_times: np.ndarray
    peak_values: np.ndarray
    period_s: float
    log_decrement: float  # (1/n) ln(r_1 / r_(1+n)) over n = 4 periods, the paper's formula
    decay_rate_per_s: float  # ln(r_1 / r_5) / (t_5 - t_1)


def fig10_free_oscillation(model: VsaUT2Model, K: float = 0.7, phi0: float = 0.2, t_end: float = 4.5) -> Oscillation:
    """Free oscillation of the output at stiffness ``K`` after release from deflection ``phi0`` (Fig. 10).

    The pivot is placed where eq. (6) gives ``K``; the frame motor is short-circuited
    (0 V) and the pivot motor idle.  Period from the first two peaks, decrement from
    peaks 1 and 5 (``n = 4``), as in Sec. III-G.
    """
    from vsa_gym.devices.vsaut2.lever import pivot_for_stiffness

    p = model.params
    q1 = float(pivot_for_stiffness(p.lever, K))
    x = model.initial_state(1, q1=min(q1, float(p.q1_max)), r=phi0)
    T = int(round(t_end / 1e-3))
    xs, _ = model.simulate(x, np.zeros((T, 1, 2)))
    t = np.arange(T + 1) * 1e-3
    r = xs[:, 0, STATE["r"]]
    idx = np.flatnonzero((r[1:-1] > r[:-2]) & (r[1:-1] >= r[2:])) + 1
    idx = idx[r[idx] > 0]
    # refine each peak with a parabola through its neighbours
    num = r[idx - 1] - r[idx + 1]
    den = r[idx - 1] - 2 * r[idx] + r[idx + 1]
    off = 0.5 * num / den
    tp = t[idx] + off * 1e-3
    rp = r[idx] - 0.25 * num * off
    if len(tp) < 5:
        raise RuntimeError(f"only {len(tp)} peaks in {t_end} s; lengthen the run")
    return Oscillation(t, r, tp, rp, float(tp[1] - tp[0]), float(np.log(rp[0] / rp[4]) / 4),
                       float(np.log(rp[0] / rp[4]) / (tp[4] - tp[0])))


class TorqueDeflection(NamedTuple):
    q1: float
    torque: np.ndarray  # external torque at the output (N m)
    deflection: np.ndarray  # r - q2_motor_side... output angle minus the locked-frame reference (rad)
    stiffness_fd: float  # slope at zero torque (N m/rad)


def fig11_torque_deflection(model: VsaUT2Model, q1: float, n_points: int = 41) -> TorqueDeflection:
    """Static torque-deflection curve at pivot ``q1`` with the frame motor locked (Fig. 11).

    The torque range is +-1.3 x the torque at which the springs reach their travel
    limit (or +-60 N m, the peak torque, if smaller), so the curves show the
    linear range and the stop.  Deflection is the output angle ``r`` (the frame
    reference at 0): it includes the belt stretch, as a measurement at the output does.
    """
    p = model.params
    lrho = p.lever.l * (p.lever.l - max(q1, p.lever.q1_min)) / max(q1, p.lever.q1_min)
    phi_lim = np.arcsin(min(1.0, p.lever.x_max / lrho)) if lrho > 0 else p.lever.phi_max
    phi_lim = min(phi_lim, p.lever.phi_max)
    tau_lim = min(float(p.lever.k * lrho**2 * np.sin(2 * phi_lim)), 60.0)
    torque = np.linspace(-1.3 * tau_lim, 1.3 * tau_lim, n_points)
    q2, r = output_equilibrium(model, q1, torque)
    return TorqueDeflection(q1, torque, r, static_output_stiffness(model, q1))


class StiffnessCurve(NamedTuple):
    q1: np.ndarray
    theory: np.ndarray  # eq. (6) at phi = 0, springs alone
    simulated: np.ndarray  # finite difference of the simulated static torque, belt in series
    belt_cap: float  # stiffness of the belt alone (N m/rad)


def fig12_stiffness(model: VsaUT2Model, n_points: int = 40) -> StiffnessCurve:
    """Output stiffness against pivot position: eq. (6) vs the model with the belt (Fig. 12)."""
    from vsa_gym.devices.vsaut2.belt import belt_stiffness_at_frame

    p = model.params
    q1 = np.linspace(0.0, float(p.q1_max), n_points)
    theory = spring_stiffness(p.lever, np.maximum(q1, 1e-4))
    sim = np.array([static_output_stiffness(model, float(q)) for q in q1])
    return StiffnessCurve(q1, theory, sim, float(belt_stiffness_at_frame(p.belt)))


class Workspace(NamedTuple):
    torque_limit: np.ndarray  # largest output torque reachable at each stiffness (N m)
    stiffness: np.ndarray  # N m/rad (belt in series)
    spring_limited: np.ndarray  # torque allowed by the spring travel / deflection stops
    drive_limit: float  # peak torque the frame drive can hold (N m)


def frame_drive_peak_torque(model: VsaUT2Model) -> float:
    """Peak static output torque of the frame drive: ``I_max k_t`` through the GP42C and the belt (N m)."""
    p = model.params
    m, gb = p.frame_motor, p.frame_gearbox
    tau_out_gb = float(static_output_torque(gb, np.array(m.I_max * m.k_t)))
    return tau_out_gb * p.belt.z_out / p.belt.z_in


def fig13_workspace(model: VsaUT2Model, n_points: int = 120) -> Workspace:
    """Reachable (stiffness, torque) pairs: spring travel and end stops vs the drive's peak torque (Fig. 13)."""
    p = model.params
    q1 = np.linspace(float(p.lever.q1_min), float(p.q1_max), n_points)
    lrho = p.lever.l * (p.lever.l - q1) / q1
    phi_lim = np.minimum(np.arcsin(np.minimum(1.0, p.lever.x_max / lrho)), p.lever.phi_max)
    spring_tau = p.lever.k * lrho**2 * np.sin(2 * phi_lim)
    drive = frame_drive_peak_torque(model)
    K_s = spring_stiffness(p.lever, q1)
    from vsa_gym.devices.vsaut2.belt import belt_stiffness_at_frame, series_stiffness

    K = series_stiffness(K_s, float(belt_stiffness_at_frame(p.belt)))
    return Workspace(np.minimum(spring_tau, drive), K, spring_tau, drive)
