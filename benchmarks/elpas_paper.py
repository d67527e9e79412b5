"""Reproduce the eLPAS paper's closed-loop results with the cascade baseline (Figs. 7-9, 14-17).

``python -m benchmarks.elpas_paper --out DIR [--quick]`` writes the figures
``elpas_fig07_09_power.png``, ``elpas_fig14_15_steps.png``, ``elpas_fig16_frf.png``,
``elpas_fig17_stiffness.png`` and ``DIR/summary.json``.

Every experiment runs the *same* controller object (:class:`baselines.elpas_cascade.ElpasCascade`)
on the force-tracking environment's task with prescribed signals
(:func:`baselines.elpas_rig.run_rig`): the paper's 10 kHz current loop, the sensors and the
energy channel are the environment's.  Frequency responses are H1 estimates
``S_xy / S_xx`` from :func:`scipy.signal.csd` / :func:`scipy.signal.welch` (Hann windows, 50 %
overlap); the bandwidth is the first frequency where ``|H|`` falls below -3 dB.

Choices the paper leaves open (stated in the summary as well):

* steps start from rest at the lookup angle of the initial force; the step comes at 0.25 s;
  mean power is taken over the 1 s after the step (and over 0.5 s, reported too), peak power over the run;
  the maximum step spans the lookup range ``gamma_ref = -85 .. 85 deg`` ([proposed], inside the
  +-90 deg stops);
* the force reference for Fig. 16 is Gaussian white noise through a 15 Hz first-order low-pass
  (paper) scaled to 10 N rms around ``F_act(0, 0)`` [proposed amplitude; the closed loop is amplitude
  dependent: at larger amplitudes gamma_ref exceeds the speed limit U_max / (K_E |N|) = 7.5 rad/s
  and the measured bandwidth drops -- 25, 50 and 150 N rms are reported too];
* Figs. 17: alpha is Gaussian white noise through the same 15 Hz low-pass, 0.2 deg rms
  [proposed], clipped to +-10 deg; "gamma = 0" is the cascade with a constant ``F_ref = F_act(0, 0)``
  and the 2-D lookup; the flying carpet uses the 3-D lookup ``gamma_ref(F_ref, alpha_hat)``;
* Figs. 7-9: force sines ``F_act(0,0) + A_F sin(2 pi f t)`` with ``A_F = F_act(A_gamma, 0) - F_act(0, 0)``,
  ``A_gamma(f)`` the Fig. 4 working range (eq. 9 with ``M_fric = 0``, ``alpha = 0``); 2 s runs, power
  statistics over the last 1 s (an integer number of periods); mean power = electrical energy drawn
  from the supply with regeneration clipped (the supply cannot take energy back) / time.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from scipy import signal  # noqa: E402

from baselines.elpas_cascade import ElpasCascade, ElpasCascadeConfig  # noqa: E402
from baselines.elpas_rig import run_rig  # noqa: E402
from vsa_gym.devices.elpas.cone import actuator_force, effective_stiffness  # noqa: E402
from vsa_gym.devices.elpas.params import ElpasParams  # noqa: E402

DT = 1e-3  # s, the force-tracking environment's control step
FORCE_NOISE_RMS = 10.0  # N [proposed]: small enough that gamma_ref stays below the speed limit
ALPHA_NOISE_RMS_DEG = 0.2  # deg [proposed]: F_act varies by about 17 N rms, the same order
EXTRA_FORCE_RMS = (25.0, 50.0, 150.0)  # N: amplitude dependence of the closed loop
PAPER = {
    "force_bandwidth_hz": 10.0, "angle_bandwidth_hz": 25.0, "small_step_mean_power_W_measured": 33.0,
    "small_step_mean_power_W_simulated": 18.0, "max_step_mean_power_W_measured": [255.0, 315.0],
    "max_step_mean_power_W_simulated": 367.0, "antiresonance_hz": 6.0, "flying_carpet_rejection_hz_sim": 8.0,
    "flying_carpet_rejection_hz_setup": 3.0,
}


# ----------------------------------------------------------------------------- helpers
def frf(x: np.ndarray, y: np.ndarray, dt: float, nperseg: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """H1 estimate of ``y / x`` and the coherence; ``x``, ``y`` of shape ``(rows, T)`` are averaged over rows."""
    x = np.atleast_2d(x) - np.mean(x, axis=-1, keepdims=True)
    y = np.atleast_2d(y) - np.mean(y, axis=-1, keepdims=True)
    f, Pxy = signal.csd(x, y, fs=1.0 / dt, nperseg=nperseg, axis=-1)
    _, Pxx = signal.welch(x, fs=1.0 / dt, nperseg=nperseg, axis=-1)
    _, Pyy = signal.welch(y, fs=1.0 / dt, nperseg=nperseg, axis=-1)
    Pxy, Pxx, Pyy = Pxy.mean(axis=0), Pxx.mean(axis=0), Pyy.mean(axis=0)
    return f, Pxy / Pxx, np.abs(Pxy) ** 2 / (Pxx * Pyy)


def bandwidth(f: np.ndarray, H: np.ndarray, f_min: float = 0.5) -> float:
    """First frequency above ``f_min`` where ``|H|`` drops below -3 dB (linear interpolation in dB)."""
    mag = 20 * np.log10(np.abs(H))
    k0 = int(np.searchsorted(f, f_min))
    below = np.flatnonzero(mag[k0:] < -3.0)
    if below.size == 0:
        return float("nan")
    k = k0 + int(below[0])
    if k == 0:
        return float(f[0])
    return float(np.interp(-3.0, [mag[k], mag[k - 1]], [f[k], f[k - 1]]))


def filtered_noise(rng: np.random.Generator, shape: tuple[int, int], cutoff_hz: float, rms: float) -> np.ndarray:
    """White noise through a first-order low-pass (``cutoff_hz``), scaled to ``rms`` per row."""
    b, a = signal.butter(1, cutoff_hz, fs=1.0 / DT)
    w = signal.lfilter(b, a, rng.standard_normal(shape), axis=-1)
    return w / np.std(w, axis=-1, keepdims=True) * rms


class RowPolicies:
    """Several policies on disjoint row sets of one batch (one batched simulation for all)."""

    def __init__(self, parts: list[tuple[np.ndarray, Any]]) -> None:
        self.parts = parts

    def reset(self) -> None:
        for _, p in self.parts:
            p.reset()

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        a = np.zeros((obs.shape[0], 1), dtype=np.float32)
        for rows, p in self.parts:
            a[rows] = p(obs[rows])
        return a

    def gamma_ref(self, n: int) -> np.ndarray:
        g = np.zeros(n)
        for rows, p in self.parts:
            g[rows] = p.last["gamma_ref"]
        return g


def no_friction(p: ElpasParams) -> ElpasParams:
    """The same rig without motor friction (LuGre levels at 1e-9 N m, no viscous or bristle damping)."""
    return p.replace(friction=p.friction.replace(F_c=1e-9, F_s=1e-9, s1=0.0, s2=0.0))


# ----------------------------------------------------------------------------- experiments
def steps(p: ElpasParams, duration: float = 1.5, t_step: float = 0.25) -> dict[str, Any]:
    """Figs. 14-15: +-100 N steps from F_act(0,0) and the maximum positive / negative steps (4 rigs)."""
    pol = ElpasCascade(ElpasCascadeConfig(dt=DT), p)
    F0 = float(actuator_force(p.cone, 0.0, 0.0))
    F_lo, F_hi = float(pol.lookup.F[0, 0]) + 0.5, float(pol.lookup.F[0, -1]) - 0.5
    T, ks = int(round(duration / DT)), int(round(t_step / DT))
    f = np.empty((4, T + 1))
    f[0], f[1], f[2], f[3] = F0, F0, F_lo, F_hi
    f[0, ks:], f[1, ks:], f[2, ks:], f[3, ks:] = F0 + 100, F0 - 100, F_hi, F_lo
    r = run_rig(pol, f, np.zeros_like(f), pol.lookup(f[:, 0]), params=p, dt=DT)
    w1, w05 = slice(ks, ks + int(1.0 / DT)), slice(ks, ks + int(0.5 / DT))
    r["mean_1s"] = r["P_charged"][:, w1].mean(axis=1)
    r["mean_05s"] = r["P_charged"][:, w05].mean(axis=1)
    r["peak"] = r["P_el"].max(axis=1)
    err = r["F_act"] - r["F_ref"]
    r["settle_error"] = err[:, -200:].mean(axis=1)
    final = f[:, -1]
    r["overshoot"] = np.array([np.max(np.sign(final[i] - f[i, 0]) * (r["F_act"][i, ks:] - final[i]))
                               for i in range(4)])
    return r


def noise_experiments(p: ElpasParams, duration: float, seed: int = 0, force_rms: float = FORCE_NOISE_RMS,
                      alpha_rms_deg: float = ALPHA_NOISE_RMS_DEG,
                      extra_force_rms: tuple[float, ...] = EXTRA_FORCE_RMS) -> dict[str, Any]:
    """Figs. 16-17 in one batch of rigs (one batched simulation).

    rows 0-1: F_ref = F_act(0,0) + filtered noise of ``force_rms`` (two realisations), alpha = 0 (Fig. 16);
    rows 2-3: alpha = filtered noise, F_ref constant: 2-D lookup ("gamma = 0", Fig. 17 left) and the
    flying carpet (3-D lookup, Fig. 17 right);
    rows 4..: force noise of the ``extra_force_rms`` amplitudes (amplitude dependence of Fig. 16).
    """
    rng = np.random.default_rng(seed)
    T = int(round(duration / DT))
    F0 = float(actuator_force(p.cone, 0.0, 0.0))
    n = 4 + len(extra_force_rms)
    f = np.full((n, T + 1), F0)
    f[:2] += filtered_noise(rng, (2, T + 1), 15.0, force_rms)
    for j, amp in enumerate(extra_force_rms):
        f[4 + j] += filtered_noise(rng, (1, T + 1), 15.0, amp)[0]
    alpha = np.zeros((n, T + 1))
    a_noise = filtered_noise(rng, (1, T + 1), 15.0, np.deg2rad(alpha_rms_deg))
    alpha[2:4] = np.clip(a_noise - a_noise[:, :1], -np.deg2rad(10), np.deg2rad(10))  # starts at alpha = 0
    base = ElpasCascade(ElpasCascadeConfig(dt=DT), p)
    carpet = ElpasCascade(ElpasCascadeConfig(dt=DT, alpha_compensation=True), p)
    plain = np.array([k for k in range(n) if k != 3])
    pol = RowPolicies([(plain, base), (np.array([3]), carpet)])
    r = run_rig(pol, f, alpha, base.lookup(f[:, 0]), params=p, dt=DT,
                record=lambda: {"gamma_ref": pol.gamma_ref(n)})
    skip = int(0.5 / DT)  # start-up transient
    nps = 2048
    out: dict[str, Any] = {"raw": r}
    out["f"], out["H_force"], out["coh_force"] = frf(r["F_ref"][:2, skip:], r["F_act"][:2, skip:], DT, nps)
    _, out["H_angle"], out["coh_angle"] = frf(r["gamma_ref"][:2, skip:], r["gamma"][:2, skip:], DT, nps)
    x = p.cone.l * np.sin(r["alpha"][2:4, skip:])
    _, out["H_stiff_gamma0"], out["coh_g0"] = frf(x[:1], r["F_hydropulse"][2:3, skip:], DT, nps)
    _, out["H_stiff_carpet"], out["coh_fc"] = frf(x[1:], r["F_hydropulse"][3:4, skip:], DT, nps)
    _, out["H_act_gamma0"], _ = frf(x[:1], r["F_act"][2:3, skip:], DT, nps)
    _, out["H_act_carpet"], _ = frf(x[1:], r["F_act"][3:4, skip:], DT, nps)
    out["amplitude_bw"] = {}
    for j, amp in enumerate(extra_force_rms):
        k = 4 + j
        _, Hf, _ = frf(r["F_ref"][k:k + 1, skip:], r["F_act"][k:k + 1, skip:], DT, nps)
        _, Ha, _ = frf(r["gamma_ref"][k:k + 1, skip:], r["gamma"][k:k + 1, skip:], DT, nps)
        out["amplitude_bw"][float(amp)] = (bandwidth(out["f"], Hf), bandwidth(out["f"], Ha))
    out["failed"] = r["failed"]
    return out


def working_range(p: ElpasParams, f: np.ndarray, m_fric: float = 0.0, m_d: float = 0.0,
                  gamma_max: float = np.deg2rad(85.0)) -> np.ndarray:
    """Eq. 9 / Fig. 4: the largest gamma sine amplitude (rad) at frequency ``f`` (position, speed, acceleration)."""
    m, d = p.motor, p.drive
    w = 2 * np.pi * np.asarray(f, dtype=np.float64)
    vel = m.U_max / (m.k_e * abs(d.N)) / w
    acc = (abs(d.N) * (m.k_t * m.I_max - m_fric) - abs(m_d)) / d.J_r / w**2
    return np.minimum(np.minimum(gamma_max, vel), acc)


def power_sweep(p: ElpasParams, freqs: np.ndarray, duration: float = 2.0) -> dict[str, Any]:
    """Figs. 7-9: worst-case power tracking force sines; rows = cases x frequencies, one batch.

    Cases: ``A_max`` at alpha = 0 with friction (reference), without friction (Fig. 7),
    ``A_max`` at alpha = -15 / +15 deg (Fig. 8), ``A_max/2`` and ``A_max/4`` at alpha = 0 (Fig. 9).
    """
    cases = [("alpha0", 1.0, 0.0, True), ("no_friction", 1.0, 0.0, False), ("alpha-15", 1.0, -15.0, True),
             ("alpha+15", 1.0, 15.0, True), ("half", 0.5, 0.0, True), ("quarter", 0.25, 0.0, True)]
    F0 = float(actuator_force(p.cone, 0.0, 0.0))
    A_gamma = working_range(p, freqs)
    A_F = actuator_force(p.cone, A_gamma, 0.0) - F0
    T = int(round(duration / DT))
    t = DT * np.arange(T + 1)
    out: dict[str, Any] = {"freqs": freqs, "A_F": A_F, "A_gamma": A_gamma, "cases": [c[0] for c in cases]}
    for friction in (True, False):
        sel = [c for c in cases if c[3] == friction]
        n = len(sel) * freqs.size
        fr = np.empty((n, T + 1))
        al = np.empty((n, T + 1))
        for j, (_, frac, a_deg, _) in enumerate(sel):
            for k, fk in enumerate(freqs):
                fr[j * freqs.size + k] = F0 + frac * A_F[k] * np.sin(2 * np.pi * fk * t)
                al[j * freqs.size + k] = np.deg2rad(a_deg)
        pp = p if friction else no_friction(p)
        pol = ElpasCascade(ElpasCascadeConfig(dt=DT), pp)
        r = run_rig(pol, fr, al, pol.lookup(fr[:, 0]), params=pp, dt=DT)
        last = slice(T - int(1.0 / DT), T)
        mean = r["P_charged"][:, last].mean(axis=1)
        peak = r["P_el"][:, last].max(axis=1)
        rms = np.sqrt(np.mean((r["F_act"][:, last] - r["F_ref"][:, last]) ** 2, axis=1))
        for j, (name, *_rest) in enumerate(sel):
            rows = slice(j * freqs.size, (j + 1) * freqs.size)
            out[name] = {"mean_W": mean[rows], "peak_W": peak[rows], "force_rms_N": rms[rows],
                         "failed": r["failed"][rows]}
    return out


# ----------------------------------------------------------------------------- figures
def _fig_steps(r: dict[str, Any], out: Path) -> None:
    fig, ax = plt.subplots(2, 4, figsize=(15, 6), sharex=True)
    titles = ("+100 N step", "-100 N step", "max positive step", "max negative step")
    for i in range(4):
        t = r["t"][i]
        ax[0, i].plot(t, r["F_ref"][i], "k--", lw=1, label="F_ref")
        ax[0, i].plot(t, r["F_act"][i], color="0.4", label="F_act (sim)")
        ax[0, i].set_title(titles[i])
        ax[1, i].plot(t, r["P_el"][i], color="0.4")
        ax[1, i].set_xlabel("t (s)")
        ax[1, i].text(0.98, 0.95, f"mean (1 s) {r['mean_1s'][i]:.0f} W\npeak {r['peak'][i]:.0f} W",
                      transform=ax[1, i].transAxes, ha="right", va="top", fontsize=8)
    ax[0, 0].set_ylabel("force (N)")
    ax[1, 0].set_ylabel("electrical power (W)")
    ax[0, 0].legend(fontsize=7)
    fig.suptitle("eLPAS cascade: force steps (paper Figs. 14-15)")
    fig.tight_layout()
    fig.savefig(out / "elpas_fig14_15_steps.png", dpi=110)
    plt.close(fig)


def _fig_frf(nx: dict[str, Any], bw: dict[str, float], out: Path) -> None:
    f = nx["f"]
    k = (f > 0.3) & (f < 100)
    fig, ax = plt.subplots(2, 2, figsize=(11, 6), sharex=True)
    for j, (key, name, b) in enumerate((("H_force", "F_ref -> F_act", bw["force"]),
                                        ("H_angle", "gamma_ref -> gamma", bw["angle"]))):
        H = nx[key]
        ax[0, j].semilogx(f[k], 20 * np.log10(np.abs(H[k])), color="0.3")
        ax[0, j].axhline(-3, color="r", lw=0.7, ls=":")
        ax[0, j].axvline(b, color="r", lw=0.7, ls=":")
        ax[0, j].set_title(f"{name}: -3 dB at {b:.1f} Hz")
        ax[1, j].semilogx(f[k], np.rad2deg(np.unwrap(np.angle(H[k]))), color="0.3")
        ax[1, j].set_xlabel("frequency (Hz)")
    ax[0, 0].set_ylabel("magnitude (dB)")
    ax[1, 0].set_ylabel("phase (deg)")
    fig.suptitle("eLPAS cascade closed loop from 15 Hz-filtered white noise, alpha = 0 (paper Fig. 16)")
    fig.tight_layout()
    fig.savefig(out / "elpas_fig16_frf.png", dpi=110)
    plt.close(fig)


def _fig_stiffness(nx: dict[str, Any], k_eff: float, s: dict[str, float], out: Path) -> None:
    f = nx["f"]
    k = (f > 0.3) & (f < 100)
    fig, ax = plt.subplots(1, 2, figsize=(11, 4), sharey=True)
    ax[0].loglog(f[k], np.abs(nx["H_stiff_gamma0"][k]), color="0.3", label="hydropulse force sensor")
    ax[0].loglog(f[k], np.abs(nx["H_act_gamma0"][k]), color="0.6", ls="--", label="F_act (no wishbone inertia)")
    ax[0].axhline(k_eff, color="k", lw=0.8, ls=":", label="design stiffness")
    ax[0].set_title(f"gamma = 0: anti-resonance {s['antiresonance_hz']:.1f} Hz")
    ax[1].loglog(f[k], np.abs(nx["H_stiff_carpet"][k]), color="0.3", label="flying carpet, sensor")
    ax[1].loglog(f[k], np.abs(nx["H_act_carpet"][k]), color="0.6", ls="--", label="flying carpet, F_act")
    ax[1].loglog(f[k], np.abs(nx["H_act_gamma0"][k]), color="0.8", lw=0.8, label="gamma = 0, F_act")
    ax[1].set_title(f"F_ref = F_act(0,0): -3 dB rejection up to {s['flying_carpet_rejection_hz']:.1f} Hz")
    for a in ax:
        a.set_xlabel("frequency (Hz)")
        a.legend(fontsize=7)
    ax[0].set_ylabel("|F / (l sin alpha)| (N/m)")
    fig.suptitle("eLPAS dynamic stiffness (paper Fig. 17)")
    fig.tight_layout()
    fig.savefig(out / "elpas_fig17_stiffness.png", dpi=110)
    plt.close(fig)


def _fig_power(sw: dict[str, Any], out: Path) -> None:
    f = sw["freqs"]
    groups = (("Fig. 7: A_max, alpha = 0", (("alpha0", "with friction", "k"), ("no_friction", "no friction", "0.6"))),
              ("Fig. 8: A_max", (("alpha-15", "alpha = -15 deg", "0.35"), ("alpha0", "alpha = 0", "k"),
                                 ("alpha+15", "alpha = +15 deg", "0.7"))),
              ("Fig. 9: alpha = 0", (("alpha0", "A_max", "k"), ("half", "A_max/2", "0.4"),
                                     ("quarter", "A_max/4", "0.7"))))
    fig, ax = plt.subplots(2, 3, figsize=(14, 7), sharex=True)
    for j, (title, lines) in enumerate(groups):
        for key, label, color in lines:
            ax[0, j].plot(f, sw[key]["peak_W"], "o-", color=color, label=label, ms=3)
            ax[1, j].plot(f, sw[key]["mean_W"], "o-", color=color, label=label, ms=3)
        ax[0, j].set_title(title)
        ax[1, j].set_xlabel("sine frequency (Hz)")
        ax[0, j].legend(fontsize=7)
    ax[0, 0].set_ylabel("peak power (W)")
    ax[1, 0].set_ylabel("mean power (W)")
    fig.suptitle("eLPAS worst-case power tracking force sines (paper Figs. 7-9)")
    fig.tight_layout()
    fig.savefig(out / "elpas_fig07_09_power.png", dpi=110)
    plt.close(fig)


# ----------------------------------------------------------------------------- main
def run(out: Path, quick: bool = False) -> dict[str, Any]:
    out.mkdir(parents=True, exist_ok=True)
    p = ElpasParams()
    t0 = time.time()
    st = steps(p)
    nx = noise_experiments(p, 6.0 if quick else 16.0)
    freqs = np.array([1, 2, 4, 6, 10, 15, 20.0]) if quick else np.array([1, 2, 3, 4, 5, 6, 8, 10, 12, 15, 20.0])
    sw = power_sweep(p, freqs)
    f = nx["f"]
    bw = {"force": bandwidth(f, nx["H_force"]), "angle": bandwidth(f, nx["H_angle"])}
    k_eff = float(effective_stiffness(p.cone, 0.0, 0.0))
    band = (f > 2) & (f < 20)
    mag0 = np.abs(nx["H_stiff_gamma0"])
    anti = float(f[band][np.argmin(mag0[band])])
    ratio = np.abs(nx["H_act_carpet"]) / np.abs(nx["H_act_gamma0"])
    k0 = int(np.searchsorted(f, 0.5))
    above = np.flatnonzero(ratio[k0:] > 1 / np.sqrt(2))
    rej = float(f[k0 + above[0]]) if above.size else float("nan")
    s: dict[str, Any] = {
        "force_bandwidth_hz": bw["force"], "angle_bandwidth_hz": bw["angle"],
        "small_step_mean_power_W": float(st["mean_1s"][:2].mean()),
        "small_step_mean_power_W_05s": float(st["mean_05s"][:2].mean()),
        "small_step_peak_power_W": float(st["peak"][:2].max()),
        "max_step_mean_power_W": float(st["mean_1s"][2:].mean()),
        "max_step_mean_power_W_05s": float(st["mean_05s"][2:].mean()),
        "max_step_peak_power_W": float(st["peak"][2:].max()),
        "step_mean_power_W_each": st["mean_1s"].tolist(),
        "step_overshoot_N": st["overshoot"].tolist(), "step_final_error_N": st["settle_error"].tolist(),
        "antiresonance_hz": anti, "design_stiffness_N_per_m": k_eff,
        "antiresonance_hz_theory": float(np.sqrt(k_eff * float(p.cone.l) ** 2 / float(p.car.J_w)) / (2 * np.pi)),
        "flying_carpet_rejection_hz": rej,
        "flying_carpet_rejection_at_1hz_dB": float(20 * np.log10(np.interp(1.0, f, ratio))),
        "bandwidth_vs_force_rms": {str(k): {"force_hz": v[0], "angle_hz": v[1]} for k, v in nx["amplitude_bw"].items()},
        "force_noise_rms_N": FORCE_NOISE_RMS, "alpha_noise_rms_deg": ALPHA_NOISE_RMS_DEG,
        "coherence_force_min_below_20hz": float(np.min(nx["coh_force"][(f > 0.5) & (f < 20)])),
        "power_sweep": {"freqs_hz": sw["freqs"].tolist(), "A_F_N": sw["A_F"].tolist(),
                        **{c: {"mean_W": sw[c]["mean_W"].tolist(), "peak_W": sw[c]["peak_W"].tolist()}
                           for c in sw["cases"]}},
        "any_end_stop_contact": bool(np.any(st["failed"]) or np.any(nx["failed"])),
        "paper": PAPER, "quick": quick,
    }
    _fig_steps(st, out)
    _fig_frf(nx, bw, out)
    _fig_stiffness(nx, k_eff, s, out)
    _fig_power(sw, out)
    s["wall_s"] = time.time() - t0
    (out / "summary.json").write_text(json.dumps(s, indent=2))
    return s


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--quick", action="store_true", help="shorter noise records and fewer sweep frequencies")
    a = ap.parse_args(argv)
    s = run(a.out, a.quick)
    keys = ("force_bandwidth_hz", "angle_bandwidth_hz", "small_step_mean_power_W", "max_step_mean_power_W",
            "antiresonance_hz", "flying_carpet_rejection_hz", "wall_s")
    print(json.dumps({k: s[k] for k in keys}, indent=2))


if __name__ == "__main__":
    main()
