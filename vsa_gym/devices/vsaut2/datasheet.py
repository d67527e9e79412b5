"""``vsa-gym datasheet vsaut2``: Table IV of the paper, each row computed from the model.

Every row states its protocol.  Rows the model cannot reproduce stay in the table
with ``model = None`` and the reason; rows that hold by construction (a parameter
was taken or calibrated from that very row) say so, so they are not mistaken for
predictions.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from vsa_gym.devices.vsaut2 import experiments as ex
from vsa_gym.devices.vsaut2.calibration import stiffness_variation_time
from vsa_gym.devices.vsaut2.model import STATE, VsaUT2Model
from vsa_gym.devices.vsaut2.params import AS5043Encoder, VsaUT2Params
from vsa_gym.devices.vsaut2.statics import static_output_stiffness
from vsa_gym.physics.dc_motor import steady_state_speed
from vsa_gym.physics.gearbox import efficiency


def _forward_input_torque(model: VsaUT2Model, tau_out_gearbox: float) -> float:
    """Motor torque the GP42C draws when delivering ``tau_out_gearbox`` forward (N m)."""
    gb = model.params.frame_gearbox
    return tau_out_gearbox / (gb.n * float(efficiency(gb, np.array(tau_out_gearbox))))


def _speed_at_torque(model: VsaUT2Model, tau_output: float) -> tuple[float, float]:
    """Steady output speed (rad/s) and motor current (A) at supply voltage for a given output torque."""
    p = model.params
    m = p.frame_motor
    belt = p.belt.z_out / p.belt.z_in
    tau_in = _forward_input_torque(model, tau_output / belt) if tau_output > 0 else \
        p.frame_gearbox.tau_max / (p.frame_gearbox.n * p.frame_gearbox.alpha * p.frame_gearbox.eta_max)
    w = steady_state_speed(m, float(m.U_max), tau_in)
    i = (m.b * w + tau_in) / m.k_t
    return float(w / p.frame_ratio), float(i)


def hysteresis_percent(model: VsaUT2Model, q1: float = 0.012, period: float = 4.0) -> float:
    """Torque hysteresis of a slow triangular output-torque sweep (frame motor shorted).

    Max torque difference between loading and unloading at equal deflection, in % of
    the peak torque (the Table IV definition as we read it).
    """
    td = ex.fig11_torque_deflection(model, q1, n_points=5)
    tau_pk = 0.8 * float(np.max(td.torque)) / 1.3
    T = int(period / 1e-3)
    t = np.arange(T) * 1e-3
    tau = tau_pk * (1 - 4 * np.abs(np.mod(t / period + 0.25, 1.0) - 0.5))  # triangle 0 -> +pk -> -pk -> 0
    x0 = model.initial_state(1, q1=q1)
    xs, _ = model.simulate(x0, np.zeros((T, 1, 2)), tau[:, None])
    defl = xs[1:, 0, STATE["r"]] - xs[1:, 0, STATE["q2"]]
    rising = np.gradient(tau) > 0
    grid = np.linspace(0.2 * defl.max(), 0.8 * defl.max(), 20)
    up = np.interp(grid, *_sorted(defl[rising & (tau > 0)], tau[rising & (tau > 0)]))
    down = np.interp(grid, *_sorted(defl[~rising & (tau > 0)], tau[~rising & (tau > 0)]))
    return float(100 * np.max(np.abs(up - down)) / tau_pk)


def _sorted(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    o = np.argsort(x)
    return x[o], y[o]


def compute(params: VsaUT2Params | None = None, as_measured: bool = True) -> list[dict[str, Any]]:
    """All Table IV rows: ``{"quantity", "unit", "paper", "model", "rel_diff", "protocol"}`` for ``params``
    (nominal by default); with ``as_measured`` (and no ``params``) each row also has ``"as_measured"`` and
    ``"rel_diff_as_measured"``, the same protocol on :meth:`VsaUT2Params.as_measured`."""
    rows = _compute(params)
    if params is None and as_measured:
        for row, other in zip(rows, _compute(VsaUT2Params.as_measured()), strict=True):
            row["as_measured"], row["rel_diff_as_measured"] = other["model"], other["rel_diff"]
    return rows


def _compute(params: VsaUT2Params | None) -> list[dict[str, Any]]:
    model = VsaUT2Model(params or VsaUT2Params())
    p = model.params
    belt = p.belt.z_out / p.belt.z_in
    rows: list[dict[str, Any]] = []

    def add(q: str, unit: str, paper: float | None, value: float | None, protocol: str) -> None:
        rel = None if value is None or paper in (None, 0) else (value - paper) / abs(paper)
        rows.append({"quantity": q, "unit": unit, "paper": paper, "model": value, "rel_diff": rel,
                     "protocol": protocol})

    nominal_torque = float(p.frame_gearbox.tau_max) * belt
    nominal_speed, nominal_current = _speed_at_torque(model, nominal_torque)
    no_load_speed, _ = _speed_at_torque(model, 0.0)
    peak = ex.frame_drive_peak_torque(model)
    K_max = static_output_stiffness(model, 0.0)
    K_min = static_output_stiffness(model, float(p.q1_max))
    t_noload = float(stiffness_variation_time(p)[0])
    t_load = float(stiffness_variation_time(p, tau_load=nominal_torque, t_max=3.0)[0])

    add("Continuous Output Power", "W", 69.8, nominal_torque * nominal_speed,
        "nominal torque x nominal speed (rows 2 and 3)")
    add("Nominal Torque", "Nm", 21.8, nominal_torque,
        "GP42C max continuous torque x 32/22 belt ratio (by construction: Table III rating)")
    add("Nominal Speed", "rad/s", 3.2, nominal_speed,
        "steady output speed at 24 V delivering the nominal torque (motor + efficiency law)")
    add("Nom. Stiffness Variation Time: no load", "s", 0.78, t_noload,
        "pivot from K_min to the stiff end at -24 V, output free (by construction: calibrates l)")
    add("Nom. Stiffness Variation Time: nom. torque", "s", 0.9, t_load if np.isfinite(t_load) else None,
        "as row 4 with the nominal torque on the output (output settles first; frame motor shorted)")
    add("Peak (Maximum) Torque", "Nm", 60.0, peak,
        "12 A x k_t through the GP42C efficiency law and the belt, static")
    add("Maximum Speed", "rad/s", 5.5, no_load_speed,
        "no-load output speed at 24 V. The paper's 5.5 rad/s equals the RE-40's 12000 rpm limit / 226.9, "
        "not a 24 V speed")
    add("Maximum Stiffness", "Nm/rad", 948.0, K_max,
        "finite difference of the static output torque at q1 = 0 (belt in series, lever at q1_min)")
    add("Minimum Stiffness", "Nm/rad", 0.7, K_min,
        "finite difference at the soft end of the stroke (by construction: K_min sets q1_max)")
    add("Maximum Elastic Energy", "J", 0.19, float(p.lever.k * p.lever.x_max**2),
        "springs at their travel limit, k x_max^2 (by construction: x_max from this row)")
    add("Maximum Torque Hysteresis", "%", 12.0, hysteresis_percent(model),
        "slow triangular torque sweep at q1 = 12 mm; the nominal model has only viscous losses, so the "
        "paper's 12 % is an effect (as-measured: the load-proportional spring hysteresis mu_h)")
    add("Maximum Deflection: max. stiffness", "deg", 2.0, float(np.rad2deg(peak / K_max)),
        "peak torque / maximum stiffness")
    add("Maximum Deflection: min. stiffness", "deg", 40.1, float(np.rad2deg(p.lever.phi_max)),
        "deflection end stop at K_min (by construction)")
    add("Active Rotation Angle", "deg", 28.6, float(np.rad2deg(p.q2_max)), "frame end stops (by construction)")
    add("Angular Resolution", "deg", 0.35, float(np.rad2deg(AS5043Encoder().resolution)),
        "10-bit output encoder step")
    add("Weight", "kg", 2.5, None, "not modelled: the model has inertias, not masses")
    add("Nominal Voltage", "V", 24.0, float(p.frame_motor.U_max), "supply voltage parameter")
    add("Nominal Current", "A", 4.0, nominal_current, "frame motor current delivering the nominal torque")
    add("Maximum Current", "A", 12.0, float(p.frame_motor.I_max), "amplifier limit parameter")
    add("Control Voltage Supply", "V", None, None, "control electronics (5 V USB, 7..12 V) are not modelled")
    add("Control Nominal Current", "A", 0.1, None, "control electronics are not modelled")
    add("I/O Protocol", "-", None, None, "RS232; not a model quantity")
    return rows


def format_table(rows: list[dict[str, Any]]) -> str:
    """The rows as a markdown table: paper, nominal model and, when the rows have it, the as-measured model."""
    both = any("as_measured" in r for r in rows)

    def num(v: float | None) -> str:
        return "-" if v is None else f"{v:.4g}"

    def rel(v: float | None) -> str:
        return "-" if v is None else f"{100 * v:+.1f} %"

    head = "| # | quantity | unit | paper | nominal | rel. diff |" + (" as-measured | rel. diff |" if both else "")
    out = [head + " protocol |", "|---" * (head.count("|")) + "|"]
    for i, r in enumerate(rows, 1):
        paper = "-" if r["paper"] is None else f"{r['paper']:g}"
        extra = f" {num(r.get('as_measured'))} | {rel(r.get('rel_diff_as_measured'))} |" if both else ""
        out.append(f"| {i} | {r['quantity']} | {r['unit']} | {paper} | {num(r['model'])} | {rel(r['rel_diff'])} |"
                   f"{extra} {r['protocol']} |")
    return "\n".join(out)
