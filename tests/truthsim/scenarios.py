"""Seeded truth cases: an axis, an experiment, a sensor and planted effects, all drawn from one seed.

API::

    case = draw_case(seed, effects=("coulomb_friction",))   # effects=(): a nominal control
    table, sidecar, truth = simulate_case(case)
    csv = write_case(case, directory)                       # <stem>.csv, <stem>.json, <stem>.truth.json

Axis kinds (load coordinates; ``n`` motor rad per load unit):

* ``ball_screw`` (translational): lead 5-20 mm (``n = 2 pi / lead``), load 5-60 kg, reflected rotor
  and screw inertia ``m_m = J n^2`` a share ``frac_m`` of 0.15-0.6 of the total; stroke amplitude
  ``A`` 3-20 cm, peak speed 0.05-0.4 m/s.  The only kind that is mounted vertically.
* ``gear_motor`` (rotational): ratio 10-100, load 0.002-0.2 kg m^2, ``frac_m`` 0.1-0.5, ``A`` 0.5-3 rad,
  peak speed 1-6 rad/s.
* ``linear_motor`` (translational direct drive, no mesh, ``m_m = 0``): 2-25 kg, current amplifier,
  ``A`` 3-20 cm, peak speed 0.1-1 m/s.

Motor constant at the load ``K = k_t n`` from an electromechanical time constant
``tau_em = m R / K^2`` of 5-60 ms; nominal mechanical viscous ``b = m / tau_v`` with ``tau_v`` 0.5-5 s.
Amplifier: voltage drive (``R`` 0.3-3 Ohm, ``L/R`` 0.2-3 ms; ``k_u = K/R``, back-EMF damping
``K^2/R`` in the sidecar's ``b``; supply sized so the design needs 25-60 % of it) or current amplifier
(bandwidth 100-1000 Hz; +-10 V command with ``G_a`` A/V sized so the design's peak force needs 25-60 % of
the range, or a logged current command, ``G_a = 1``; ``k_u = K G_a``).  Rate from {200, 500, 1000, 2000,
5000} Hz, duration 5-20 s.  Loop: open (multisine / chirp / steps) or closed (moves / sines / multisine),
closed always for a vertical axis or a constant load force; a closed-loop record declares its controller
(``replay: closed_loop``, 70 %) or not (``open_loop``).  PD gains place the nominal loop at ``f_n`` 3-12 Hz
(``<= rate/40``, ``<= 0.3`` of a compliance mode, ``<= 0.05/delay``, and one encoder count of derivative
kick ``<= 0.2 F_pk``; damping 0.6-1); commissioning (:func:`_tune`) lowers ``f_n`` until the real axis runs
stably; the saturation is the amplifier's range.  Encoder: at the motor (4096-2^18 counts/rev, expressed
at the load) or at the load (linear scale 0.1-5 um, rotary 2^14-2^18 counts/rev), floor or round, white
noise 0.1-1 count.

Planted magnitudes (uniform; +- a random sign where marked), relative to the design's peak drive
force ``F_pk``, peak speed ``v_pk``, amplitude ``A`` and the encoder step ``res`` (at the load):

=========================  =====================================================================
coulomb_friction.F_c       0.03-0.15 F_pk
stribeck_friction.F_s      0.03-0.12 F_pk, v_s 0.02-0.15 v_pk, exponent delta 1-2
viscous_friction.b         extra ``b v_pk`` = 0.05-0.25 F_pk
backlash.width             2 g = 5 res ... 0.005 (2 A); shaft 50-120 Hz (zeta 0.05-0.2) in series,
                           contact k_b = 3-10 k_s (zeta 0.1-0.5)
transmission_compliance    1/k_s, mode ``sqrt(k_s / m_r)`` 4-30 Hz (<= rate/6), zeta 0.02-0.1,
                           ``m_r = m_m m_l / (m_m + m_l)``
gearbox_efficiency.loss    1 - eta_f = 0.1-0.4; ball screw eta_b = max(2 - 1/eta_f, 0.3) (textbook
                           lead-screw relation), gear eta_b = eta_f x U(0.85, 1)
hysteresis.F_h             Dahl F_hmax 0.03-0.15 F_pk, presliding F_h/sigma 0.2-2 % of A (>= 3 res)
inertia_error.rel          +-0.1-0.4 (load and rotor inertia both scaled by 1 + rel)
force_offset.F_0           vertical: gravity m_l g (0.15-0.45 of the total peak force); else +-0.03-0.15 F_pk
sensor_gain.gain           +-0.02-0.08
sensor_offset.offset       +-0.02-0.1 A
sensor_delay.delay         max(1.5 dt, 1 ms) ... max(6 dt, 5 ms)
=========================  =====================================================================
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from tests.truthsim import excitation as ex
from tests.truthsim.plant import param_vector

EFFECTS: tuple[str, ...] = (
    "coulomb_friction", "stribeck_friction", "viscous_friction", "backlash", "transmission_compliance",
    "gearbox_efficiency", "hysteresis", "inertia_error", "force_offset", "sensor_gain", "sensor_offset",
    "sensor_delay",
)
#: the main parameter of each effect, in the identifier catalogue's meaning
MAIN: dict[str, str] = {
    "coulomb_friction": "F_c", "stribeck_friction": "F_s", "viscous_friction": "b", "backlash": "width",
    "transmission_compliance": "compliance", "gearbox_efficiency": "loss", "hysteresis": "F_h",
    "inertia_error": "rel", "force_offset": "F_0", "sensor_gain": "gain", "sensor_offset": "offset",
    "sensor_delay": "delay",
}
RATES: tuple[int, ...] = (200, 500, 1000, 2000, 5000)
GRAVITY = 9.81  # m/s^2
NEEDS_MESH = {"backlash", "transmission_compliance", "gearbox_efficiency"}


@dataclasses.dataclass(eq=False)
class Case:
    """One drawn truth case (everything the simulation needs; see the module docstring for ranges)."""

    seed: int
    effects: tuple[str, ...]
    axis: str  # ball_screw | gear_motor | linear_motor
    motion: str  # translational | rotational
    vertical: bool
    amplifier: str  # voltage | current
    command: str  # logged drive input quantity: voltage | current
    rate: float  # Hz
    duration: float  # s
    loop: str  # open | closed
    replay: str  # open_loop | closed_loop (what the sidecar declares)
    excitation: str  # multisine | chirp | steps | sines | moves
    x0: float  # initial load position (m or rad)
    gap0: float  # initial motor position inside the backlash gap (m or rad)
    params: dict[str, float]  # true plant parameters (plant.PAR_NAMES)
    nominal: dict[str, float]  # sidecar model parameters (m, b, k_u, tau_e, frac_m, v_eps)
    planted: dict[str, dict[str, float]]  # effect -> its parameters (main one first)
    sensor: dict[str, Any]  # at, resolution, quantizer, noise_counts, gain, offset, delay, description
    controller: dict[str, float] | None  # kp, kv, saturation (closed loop)
    u: np.ndarray | None  # open-loop drive command (input units)
    ref: np.ndarray | None  # closed-loop reference (m or rad, absolute)
    design: dict[str, Any]  # amplitude, v_peak, F_peak, transmission and motor data, ...

    @property
    def dt(self) -> float:
        return 1.0 / self.rate

    @property
    def n(self) -> int:
        return int(round(self.duration * self.rate))

    def summary(self) -> str:
        """One line: axis, amplifier, loop / replay, excitation, rate, duration, sensor."""
        v = "vertical " if self.vertical else ""
        return (f"{v}{self.axis} {self.amplifier}-amp {self.loop}-loop/{self.replay} {self.excitation} "
                f"{self.rate:g} Hz {self.duration:.1f} s enc@{self.sensor['at']}")

    def P(self) -> np.ndarray:
        """Plant parameter vector (:func:`tests.truthsim.plant.param_vector`)."""
        return param_vector(**self.params)


def _signed(rng: np.random.Generator, lo: float, hi: float) -> float:
    v = float(rng.uniform(lo, hi))
    return v if rng.random() < 0.5 else -v


def _axis(rng: np.random.Generator, effects: tuple[str, ...]) -> tuple[str, bool]:
    vertical = "force_offset" in effects and ("coulomb_friction" in effects or rng.random() < 0.5)
    if vertical:
        return "ball_screw", True
    kinds = ["ball_screw", "gear_motor"] if NEEDS_MESH & set(effects) else ["ball_screw", "gear_motor", "linear_motor"]
    return str(rng.choice(kinds)), False


def _mechanics(rng: np.random.Generator, axis: str, vertical: bool) -> dict[str, float]:
    """Load and reflected rotor inertia, ratio, stroke amplitude and peak speed (load coordinates)."""
    if axis == "ball_screw":
        lead = rng.uniform(5e-3, 20e-3)
        m_l = rng.uniform(5.0, 40.0 if vertical else 60.0)
        frac = rng.uniform(0.15, 0.6)
        return {"ratio": 2 * np.pi / lead, "lead": lead, "m_l": m_l, "m_m": frac / (1 - frac) * m_l,
                "A": rng.uniform(0.03, 0.2), "v_peak": rng.uniform(0.05, 0.4)}
    if axis == "gear_motor":
        J_l = rng.uniform(0.002, 0.2)
        frac = rng.uniform(0.1, 0.5)
        return {"ratio": rng.uniform(10.0, 100.0), "lead": 0.0, "m_l": J_l, "m_m": frac / (1 - frac) * J_l,
                "A": rng.uniform(0.5, 3.0), "v_peak": rng.uniform(1.0, 6.0)}
    return {"ratio": 1.0, "lead": 0.0, "m_l": rng.uniform(2.0, 25.0), "m_m": 0.0, "A": rng.uniform(0.03, 0.2),
            "v_peak": rng.uniform(0.1, 1.0)}


def _motor(rng: np.random.Generator, axis: str, m_tot: float) -> dict[str, Any]:
    amp = "current" if axis == "linear_motor" or rng.random() < 0.5 else "voltage"
    R = rng.uniform(0.3, 3.0)
    tau_em = rng.uniform(5e-3, 60e-3)
    K = np.sqrt(m_tot * R / tau_em) if axis != "linear_motor" else rng.uniform(20.0, 150.0)
    out: dict[str, Any] = {"amplifier": amp, "K": K, "R": R}
    if amp == "voltage":
        tau_e = rng.uniform(0.2e-3, 3e-3)
        out.update(command="voltage", L=tau_e * R, tau_e=tau_e, tau_c=1e-3, b_emf=K**2 / R)
    else:
        f_bw = rng.uniform(100.0, 1000.0)
        cmd = "voltage" if rng.random() < 0.6 else "current"
        out.update(command=cmd, L=1e-3, tau_e=1 / (2 * np.pi * f_bw), f_bw=f_bw, tau_c=1 / (2 * np.pi * f_bw),
                   b_emf=0.0)
    return out


def _size_amplifier(rng: np.random.Generator, mot: dict[str, Any], F_peak: float, u_volt: float) -> None:
    """Amplifier gain and range for a design needing ``F_peak`` (N) at most, 25-60 % of the range.

    Current amplifier with a +-10 V command: ``G_a = (F_peak / K) / (use 10 V)``; with a logged current
    command: ``G_a = 1``, range ``I_max = F_peak / (K use)``.  Voltage drive: ``k_u = K/R``, supply
    ``V = max|u| / use`` (``u_volt``: the design's peak voltage).
    """
    use = rng.uniform(0.25, 0.6)
    if mot["amplifier"] == "voltage":
        mot.update(G_a=1.0, k_u=mot["K"] / mot["R"], u_limit=u_volt / use)
    elif mot["command"] == "voltage":
        mot.update(G_a=F_peak / mot["K"] / (use * 10.0), u_limit=10.0)
        mot["k_u"] = mot["K"] * mot["G_a"]
    else:
        mot.update(G_a=1.0, k_u=mot["K"], u_limit=F_peak / mot["K"] / use)


def _sensor(rng: np.random.Generator, axis: str, mech: dict[str, float]) -> dict[str, Any]:
    rot = axis == "gear_motor"
    at = "load" if axis == "linear_motor" or rng.random() < 0.4 else "motor"
    if at == "motor":
        cpr = int(rng.choice([4096, 10000, 2**16, 2**18]))
        res = (mech["lead"] if axis == "ball_screw" else 2 * np.pi / mech["ratio"]) / cpr
        desc = f"motor encoder, {cpr} counts/rev, expressed at the load"
    elif rot:
        cpr = int(rng.choice([2**14, 2**16, 2**18]))
        res, desc = 2 * np.pi / cpr, f"load encoder, {cpr} counts/rev"
    else:
        res = float(rng.choice([0.1e-6, 0.5e-6, 1e-6, 5e-6]))
        desc = f"linear scale, {res * 1e6:g} um"
    return {"at": at, "resolution": float(res), "quantizer": str(rng.choice(["floor", "round"])),
            "noise_counts": float(rng.uniform(0.1, 1.0)), "gain": 0.0, "offset": 0.0, "delay": 0.0,
            "description": desc}


def _path(rng: np.random.Generator, kind: str, t: np.ndarray, A: float, v_pk: float, rate: float,
          current_mode: bool) -> np.ndarray:
    f_hi = min(rng.uniform(2.0, 8.0), rate / 25)
    f_lo = rng.uniform(0.1, 0.4)
    if kind == "multisine":
        return ex.multisine(rng, t, A, v_pk, f_lo, f_hi, current_mode)
    if kind == "chirp":
        return ex.chirp(rng, t, A, v_pk, f_lo, f_hi, current_mode)
    if kind == "sines":
        return ex.sines(rng, t, A, v_pk)
    return ex.moves(rng, t, A, v_pk)


def _plant(rng: np.random.Generator, effects: tuple[str, ...], params: dict[str, float], sensor: dict[str, Any],
           sc: dict[str, Any]) -> tuple[dict[str, dict[str, float]], bool]:
    """Draw the planted magnitudes (ranges in the module docstring) into ``params`` / ``sensor``.

    ``sc``: the design scales ``F_peak, v, A, res, m_r, axis, rate, dt, vertical, b_mech``.  Returns the planted
    parameters per effect and whether a stiff shaft was added in series with a backlash.
    """
    F_peak, v_design, A_design, res, m_r = sc["F_peak"], sc["v"], sc["A"], sc["res"], sc["m_r"]
    axis, rate, dt, vertical, b_mech = sc["axis"], sc["rate"], sc["dt"], sc["vertical"], sc["b_mech"]
    planted: dict[str, dict[str, float]] = {}
    shaft_stiff = False
    for eff in effects:
        if eff == "coulomb_friction":
            planted[eff] = {"F_c": rng.uniform(0.03, 0.15) * F_peak}
            params["F_c"] = planted[eff]["F_c"]
        elif eff == "stribeck_friction":
            planted[eff] = {"F_s": rng.uniform(0.03, 0.12) * F_peak, "v_s": rng.uniform(0.02, 0.15) * v_design,
                            "delta": rng.uniform(1.0, 2.0)}
            params.update(F_s=planted[eff]["F_s"], v_s=planted[eff]["v_s"], delta=planted[eff]["delta"])
        elif eff == "viscous_friction":
            planted[eff] = {"b": rng.uniform(0.05, 0.25) * F_peak / v_design}
            params["b"] = b_mech + planted[eff]["b"]
        elif eff == "backlash":
            hi = 0.005 * 2 * A_design
            width = rng.uniform(min(5 * res, 0.5 * hi), hi)
            f_s, z_s = rng.uniform(50.0, 120.0), rng.uniform(0.05, 0.2)
            k_s = (2 * np.pi * f_s) ** 2 * m_r
            k_b, z_b = rng.uniform(3.0, 10.0) * k_s, rng.uniform(0.1, 0.5)
            planted[eff] = {"width": width, "k_b": k_b, "c_b": 2 * z_b * np.sqrt(k_b * m_r), "shaft_hz": f_s}
            params.update(g=width / 2, k_b=k_b, c_b=planted[eff]["c_b"])
            if "transmission_compliance" not in effects:
                params.update(k_s=k_s, c_s=2 * z_s * np.sqrt(k_s * m_r))
                shaft_stiff = True
        elif eff == "transmission_compliance":
            f_c = rng.uniform(4.0, min(30.0, rate / 6))
            k_s = (2 * np.pi * f_c) ** 2 * m_r
            z = rng.uniform(0.02, 0.1)
            planted[eff] = {"compliance": 1.0 / k_s, "k_s": k_s, "c_s": 2 * z * np.sqrt(k_s * m_r), "mode_hz": f_c}
            params.update(k_s=k_s, c_s=planted[eff]["c_s"])
        elif eff == "gearbox_efficiency":
            loss = rng.uniform(0.1, 0.4)
            eta_f = 1 - loss
            eta_b = max(2 - 1 / eta_f, 0.3) if axis == "ball_screw" else eta_f * rng.uniform(0.85, 1.0)
            planted[eff] = {"loss": loss, "eta_f": eta_f, "eta_b": eta_b}
            params.update(eta_f=eta_f, eta_b=eta_b)
        elif eff == "hysteresis":
            F_h = rng.uniform(0.03, 0.15) * F_peak
            x_h = max(rng.uniform(0.002, 0.02) * A_design, 3 * res)
            planted[eff] = {"F_h": F_h, "sigma": F_h / x_h}
            params.update(F_h=F_h, sigma_h=F_h / x_h)
        elif eff == "inertia_error":
            rel = _signed(rng, 0.1, 0.4)
            planted[eff] = {"rel": rel}
            params.update(m_l=params["m_l"] * (1 + rel), m_m=params["m_m"] * (1 + rel))
        elif eff == "force_offset":
            F_0 = 0.0 if vertical else _signed(rng, 0.03, 0.15) * F_peak  # vertical: gravity, set by the caller
            planted[eff] = {"F_0": F_0, "gravity": float(vertical)}
            params["F_0"] = F_0
        elif eff == "sensor_gain":
            planted[eff] = {"gain": _signed(rng, 0.02, 0.08)}
            sensor["gain"] = planted[eff]["gain"]
        elif eff == "sensor_offset":
            planted[eff] = {"offset": _signed(rng, 0.02, 0.1) * A_design}
            sensor["offset"] = planted[eff]["offset"]
        elif eff == "sensor_delay":
            planted[eff] = {"delay": rng.uniform(max(1.5 * dt, 1e-3), max(6 * dt, 5e-3))}
            sensor["delay"] = planted[eff]["delay"]
    return planted, shaft_stiff


def _pd_gains(f_n: float, zeta: float, m: float, b: float, k_u: float, sat: float) -> dict[str, float]:
    """PD gains placing the nominal loop ``m s^2 + (b + k_u kv) s + k_u kv kp`` at ``f_n`` Hz, damping ``zeta``
    (``k_u kv >= 0.2 (2 zeta w m)`` where the viscous / back-EMF damping alone would already exceed it)."""
    w = 2 * np.pi * f_n
    c_tot = 2 * zeta * w * m
    kv = max(c_tot - b, 0.2 * c_tot) / k_u
    return {"kp": float(w**2 * m / (k_u * kv)), "kv": float(kv), "saturation": float(sat), "f_n": float(f_n),
            "zeta": float(zeta)}


def draw_case(seed: int, effects: tuple[str, ...] = (), *, rate: float | None = None,
              duration: float | None = None) -> Case:
    """Draw axis, experiment, sensor and the magnitudes of ``effects`` from ``seed`` (``()``: nominal control).

    ``rate`` (Hz) / ``duration`` (s) replace the drawn sample rate / length (e.g. 1000 and 20 for the time
    target of an identification, per 20 s at 1 kHz); the rest is drawn from ``seed`` as always, the designs
    that depend on the rate (loop bandwidth, compliance mode) bounded by the rate given."""
    for name, v in (("rate", rate), ("duration", duration)):
        if v is not None and not v > 0:
            raise ValueError(f"draw_case: {name} must be > 0, got {v}")
    given_rate, given_duration = rate, duration
    effects = tuple(effects)
    bad = [e for e in effects if e not in EFFECTS]
    if bad or len(set(effects)) != len(effects):
        raise ValueError(f"effects must be distinct names of {EFFECTS}, got {effects}")
    rng = np.random.default_rng([seed, 7919])
    axis, vertical = _axis(rng, effects)
    mech = _mechanics(rng, axis, vertical)
    m_l, m_m = mech["m_l"], mech["m_m"]
    m_nom = m_l + m_m
    mot = _motor(rng, axis, m_nom)
    b_mech = m_nom / rng.uniform(0.5, 5.0)
    b_nom = b_mech + mot["b_emf"]
    rate = float(rng.choice(RATES))
    duration = float(np.round(rng.uniform(5.0, 20.0), 2))
    rate, duration = float(given_rate or rate), float(given_duration or duration)  # the draws are made either way
    dt = 1.0 / rate
    t = np.arange(int(round(duration * rate))) * dt
    # a constant load force would run an open-loop axis away: such axes are tested in closed loop
    loop = "closed" if rng.random() < 0.5 or vertical or "force_offset" in effects else "open"
    replay = ("closed_loop" if rng.random() < 0.7 else "open_loop") if loop == "closed" else "open_loop"
    kind = str(rng.choice(["multisine", "chirp", "steps"] if loop == "open" else ["moves", "sines", "multisine"]))
    A, v_pk = mech["A"], mech["v_peak"]
    x0 = float(np.round(rng.uniform(-0.5, 0.5) * A, 4))
    sensor = _sensor(rng, axis, mech)
    current_cmd = mot["amplifier"] == "current"
    f_grav = 0.0
    if kind == "steps":  # drive force (k_u = 1)
        F = ex.steps(rng, t, A, v_pk, m_nom, b_nom, 1.0, current_cmd)
        r = None
    else:
        r = _path(rng, kind, t, A, v_pk, rate, current_cmd and loop == "open")
        if vertical:  # scale the motion so that gravity is 15-45 % of the peak drive force
            frac_g = rng.uniform(0.15, 0.45)
            f_dyn = float(np.max(np.abs(ex.feedforward(r, dt, m_nom, b_nom))))
            r = r * np.clip(m_l * GRAVITY * (1 - frac_g) / frac_g / f_dyn, 0.2, 5.0)
            f_grav = m_l * GRAVITY
        F = ex.feedforward(r, dt, m_nom, b_nom)
    F_peak = float(np.max(np.abs(F + f_grav)))
    _size_amplifier(rng, mot, F_peak, F_peak * mot["R"] / mot["K"])
    k_u, u_lim = mot["k_u"], mot["u_limit"]
    u = F / k_u
    v_design = float(np.max(np.abs(ex.derivative(r, dt)))) if r is not None else v_pk
    A_design = float(np.max(np.abs(r))) if r is not None else A

    params: dict[str, float] = {"m_l": m_l, "m_m": m_m, "b": b_mech, "amp": 0.0 if mot["amplifier"] == "voltage"
                                else 1.0, "K": mot["K"], "R": mot["R"], "L": mot["L"], "G_a": mot["G_a"],
                                "tau_c": mot["tau_c"]}
    sc = {"F_peak": F_peak, "v": v_design, "A": A_design, "res": sensor["resolution"], "axis": axis, "rate": rate,
          "dt": dt, "vertical": vertical, "b_mech": b_mech, "m_r": m_l * m_m / m_nom if m_m > 0 else m_l}
    planted, shaft_stiff = _plant(rng, effects, params, sensor, sc)
    if vertical:  # gravity on the true load mass (after an inertia error, if any)
        f_grav = params["m_l"] * GRAVITY
        planted["force_offset"]["F_0"] = params["F_0"] = f_grav
    gap0 = 0.0
    if "backlash" in planted:
        g = planted["backlash"]["width"] / 2
        gap0 = g if vertical else float(rng.uniform(-g, g))

    controller = None
    ref = None
    if loop == "closed":
        assert r is not None
        f_mode = planted.get("transmission_compliance", {}).get("mode_hz", np.inf)
        zeta = rng.uniform(0.6, 1.0)
        # derivative of one encoder count must not kick more than 20 % of F_peak: zeta w m res / dt <= 0.2 F_peak
        w_noise = 0.2 * F_peak * dt / (zeta * m_nom * sensor["resolution"])
        f_n = min(rng.uniform(3.0, 12.0), rate / 40, 0.3 * f_mode, 0.05 / max(sensor["delay"], 1e-9),
                  max(w_noise / (2 * np.pi), 1.0))
        controller = _pd_gains(f_n, zeta, m_nom, b_nom, k_u, u_lim)
        ref = x0 + r
        u = None
    design = {"amplitude": A_design, "v_peak": v_design, "F_peak": F_peak, "F_gravity": f_grav, "ratio": mech["ratio"],
              "lead": mech["lead"], "m_nominal": m_nom, "b_mech_nominal": b_mech, "b_emf": mot["b_emf"], "k_u": k_u,
              "tau_e": mot["tau_e"], "k_t": mot["K"] / mech["ratio"], "G_a": mot["G_a"],
              "J_m": m_m / mech["ratio"] ** 2, "u_limit": u_lim, "shaft_stiff": shaft_stiff, "f_bw": mot.get("f_bw")}
    nominal = {"m": m_nom, "b": b_nom, "k_u": k_u, "tau_e": mot["tau_e"], "v_eps": 1e-3 * v_design}
    if m_m > 0:
        nominal["frac_m"] = m_m / m_nom
    # half the users of a voltage drive also give the back-EMF part of b (docs/measured-data.md), half do not
    # (a stream of its own, so that the coin is independent of the case's other draws)
    if mot["b_emf"] > 0 and np.random.default_rng([seed, 7919, 1]).random() < 0.5:
        nominal["b_emf"] = mot["b_emf"]
    case = Case(seed, effects, axis, "rotational" if axis == "gear_motor" else "translational", vertical,
                mot["amplifier"], mot["command"], rate, duration, loop, replay, kind, x0, gap0,
                {k: float(v) for k, v in params.items()}, {k: float(v) for k, v in nominal.items()},
                {e: {k: float(v) for k, v in p.items()} for e, p in planted.items()}, sensor, controller,
                None if u is None else np.asarray(u, dtype=np.float64), ref, design)
    if loop == "closed":
        _tune(case)
    return case


def _tune(case: Case, tries: int = 6) -> None:
    """Commissioning: lower the loop's natural frequency by 0.6x until the run on the real axis is stable:
    at most 2 % of the samples at the limit and an rms tracking error below 2 A (no run-away)."""
    from tests.truthsim.records import run

    assert case.controller is not None and case.ref is not None
    c = case.controller
    for i in range(tries):
        sim = run(case)
        sat = float(np.mean(np.abs(sim.u) >= 0.999 * c["saturation"]))
        err = float(np.sqrt(np.mean((sim.y - case.ref) ** 2)))
        ok = bool(np.all(np.isfinite(sim.y))) and sat <= 0.02 and err <= 2.0 * case.design["amplitude"]
        case.design.update(tuning_steps=i, loop_ok=ok, saturated_fraction=sat, rms_tracking_error=err)
        if ok or i == tries - 1:
            return
        c.update(_pd_gains(0.6 * c["f_n"], c["zeta"], case.nominal["m"], case.nominal["b"], case.nominal["k_u"],
                           c["saturation"]))


def simulate_case(case: Case) -> tuple[pd.DataFrame, dict[str, Any], dict[str, Any]]:
    """Run the case: the measured table, the user's sidecar and the truth (see :mod:`tests.truthsim.records`)."""
    from tests.truthsim.records import run_case

    return run_case(case)


def write_case(case: Case, directory: str | Path) -> Path:
    """Simulate and write ``<stem>.csv``, ``<stem>.json`` (sidecar) and ``<stem>.truth.json``; returns the CSV path."""
    from tests.truthsim.records import write_record

    table, sidecar, truth = simulate_case(case)
    return write_record(Path(directory), case, table, sidecar, truth)


__all__ = ["EFFECTS", "MAIN", "RATES", "Case", "draw_case", "simulate_case", "write_case"]
