"""Run every baseline on its environment over fixed seeds and tabulate the metrics.

``python -m benchmarks.baselines [--quick] [--json FILE] [--md FILE] [--plots DIR]``

Rows: each baseline of :mod:`baselines` on the environment it is built for, plus the zero and
the random policy on the same environment settings, plus the ideal-force skyhook *reference*
for the quarter car (a linear model with an ideal force actuator: no motor, no limits -- an upper
reference, not a policy on the environment).  Metrics: :func:`baselines.metrics.evaluate_policy`
(the same function the RL agents are evaluated with).  ``--quick`` uses 2 seeds and short
episodes (under two minutes on an idle machine); the default uses 3 seeds and 2 s (force tracking),
5 s (position/stiffness, the registered length) and 5 s (quarter car) episodes.

Environment settings: the eLPAS baselines drive the paper's current loop (``control_mode="current"``);
the quarter car runs on the registered default, an ISO 8608 class B road at 20 m/s with a light 300 N s/m
parallel damper (``vsa_gym.devices.elpas.env_quarter_car.TASK_PARALLEL_DAMPER``): on class C this light car lifts a
wheel within about a second whatever the controller does, and with a 1.2 kN s/m damper the damper's 4-12 Hz
transmission dominates the W_k comfort metric, which no body-velocity controller can then move.
"""

from __future__ import annotations

import argparse
import json
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from baselines.elpas_cascade import ElpasCascadeConfig, elpas_cascade_factory  # noqa: E402
from baselines.metrics import evaluate_policy, random_policy_factory, zero_policy_factory  # noqa: E402
from baselines.quarter_car import ideal_skyhook_reference, passive_factory, skyhook_factory  # noqa: E402
from baselines.vsaut2_decoupled import vsaut2_decoupled_factory  # noqa: E402

FT = "vsa_gym/ELPAS-ForceTracking-v0"
QC = "vsa_gym/ELPAS-QuarterCar-v0"
PS = "vsa_gym/VsaUT2-PositionStiffness-v0"
ENV_KWARGS: dict[str, dict[str, Any]] = {
    FT: {"control_mode": "current"},
    QC: {"control_mode": "current", "road_class": "B"},
    PS: {},
}
BASELINES: list[tuple[str, str, Callable[[Any], Any]]] = [
    ("eLPAS cascade (paper: 2-D lookup)", FT, elpas_cascade_factory()),
    ("eLPAS cascade + 3-D lookup (alpha-compensated)", FT, elpas_cascade_factory(
        ElpasCascadeConfig(alpha_compensation=True))),
    ("vsaUT-II decoupled PID + feed-forward", PS, vsaut2_decoupled_factory()),
    ("passive (eLPAS held at gamma = 0)", QC, passive_factory()),
    ("skyhook through the eLPAS cascade", QC, skyhook_factory()),
]
REFERENCES: list[tuple[str, Callable[[Any], Any]]] = [("zero policy", zero_policy_factory),
                                                       ("random policy", random_policy_factory)]
COLUMNS = (("tracking / comfort", None), ("energy_J", "{:.1f}"), ("peak_power_W", "{:.0f}"),
           ("violations", "{:d}"), ("steps", "{:.0f}"))


def _tracking(row: dict[str, Any]) -> str:
    if "force_rms_N" in row:
        return f"force RMS {row['force_rms_N']:.1f} N"
    if "position_rms_rad" in row:
        return (f"position RMS {row['position_rms_rad']:.3f} rad, ln K RMS {row['log_stiffness_rms']:.2f} "
                f"({100 * row['stiffness_rel_rms']:.0f} %)")
    if "comfort_aw_rms" in row:
        return (f"a_w {row['comfort_aw_rms']:.3f} m/s^2, travel RMS {1e3 * row['travel_rms_m']:.1f} mm, "
                f"tyre load RMS {100 * row['tyre_load_rms']:.1f} %")
    return f"return {row['return']:.1f}"


def markdown(rows: list[dict[str, Any]]) -> str:
    lines = ["| environment | policy | tracking / comfort | energy (J) | peak power (W) | violations | steps |",
             "|---|---|---|---|---|---|---|"]
    for r in rows:
        env = r["env_id"].split("/")[-1]
        if r.get("reference_only"):
            lp = r["linear_passive"]
            lines.append(f"| {env} | {r['policy']} | {_tracking(r)}; same linear car passive: a_w "
                         f"{lp['comfort_aw_rms']:.3f} m/s^2, travel RMS {1e3 * lp['travel_rms_m']:.1f} mm"
                         f" | -- | -- | -- | {r['steps']:.0f} |")
            continue
        lines.append(f"| {env} | {r['policy']} | {_tracking(r)} | {r['energy_J']:.1f} | {r['peak_power_W']:.0f} | "
                     f"{r['violations']} / {r['episodes']} | {r['steps']:.0f} |")
    return "\n".join(lines)


def run(quick: bool = False) -> dict[str, Any]:
    seeds = [0, 1] if quick else [0, 1, 2]
    steps = {FT: 600, QC: 500, PS: 500} if quick else {FT: 2000, QC: 2500, PS: None}
    rows: list[dict[str, Any]] = []
    t0 = time.time()
    for env_id in (FT, PS, QC):
        entries = [(n, f) for n, e, f in BASELINES if e == env_id] + REFERENCES
        for name, fac in entries:
            r = evaluate_policy(env_id, fac, seeds, episode_steps=steps[env_id], env_kwargs=ENV_KWARGS[env_id])
            r["policy"] = name
            r["baseline"] = (name, fac) not in REFERENCES
            r["env_kwargs"] = ENV_KWARGS[env_id]
            rows.append(r)
            print(f"{time.time() - t0:6.1f} s  {env_id.split('/')[-1]:28s} {name:48s} {_tracking(r)}", flush=True)
        if env_id == QC:
            n_steps = int(max(max(r["per_episode"]["steps"]) for r in rows if r["env_id"] == QC))
            ref = ideal_skyhook_reference(seeds, n_steps, env_kwargs=ENV_KWARGS[QC])
            rows.append({"env_id": QC, "policy": "ideal-force skyhook (upper reference, ignores actuator limits)",
                         "reference_only": True, "episodes": len(seeds), "steps": float(n_steps),
                         "comfort_aw_rms": ref["comfort_aw_rms"], "travel_rms_m": ref["travel_rms_m"],
                         "tyre_load_rms": ref["tyre_load_rms"], "linear_passive": ref["passive_linear"],
                         "metric": "comfort_aw_rms", "metric_value": ref["comfort_aw_rms"]})
    return {"rows": rows, "seeds": seeds, "quick": quick, "wall_s": time.time() - t0}


def plot(result: dict[str, Any], out: Path) -> list[Path]:
    out.mkdir(parents=True, exist_ok=True)
    rows = result["rows"]
    envs = list(dict.fromkeys(r["env_id"] for r in rows))
    fig, ax = plt.subplots(2, len(envs), figsize=(5.5 * len(envs), 7))
    for j, env in enumerate(envs):
        rr = [r for r in rows if r["env_id"] == env]
        names = [r["policy"] for r in rr]
        vals = [r["metric_value"] for r in rr]
        colors = ["tab:blue" if r.get("baseline") else ("tab:green" if r.get("reference_only") else "0.6")
                  for r in rr]
        y = np.arange(len(rr))
        ax[0, j].barh(y, vals, color=colors)
        ax[0, j].set_yticks(y, [n[:38] for n in names], fontsize=7)
        ax[0, j].set_title(f"{env.split('/')[-1]}: {rr[0]['metric']}", fontsize=9)
        ax[0, j].invert_yaxis()
        en = [r.get("energy_J", np.nan) for r in rr]
        ax[1, j].barh(y, en, color=colors)
        ax[1, j].set_yticks(y, [n[:38] for n in names], fontsize=7)
        ax[1, j].set_title("electrical energy per episode (J)", fontsize=9)
        ax[1, j].invert_yaxis()
    fig.suptitle(f"Baselines (blue) vs zero / random policies (grey); seeds {result['seeds']}"
                 + (" -- quick" if result["quick"] else ""))
    fig.tight_layout()
    path = out / ("baselines_metrics_quick.png" if result["quick"] else "baselines_metrics.png")
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return [path]


def paper_markdown(summary: dict[str, Any]) -> str:
    """The eLPAS paper comparison (Figs. 7-9, 14-17) from ``benchmarks.elpas_paper``'s summary.json."""
    s, pp = summary, summary["paper"]
    bw = s.get("bandwidth_vs_force_rms", {})
    amp = ", ".join(f"{float(k):.0f} N: {v['force_hz']:.1f} / {v['angle_hz']:.1f} Hz" for k, v in bw.items())
    sw = s["power_sweep"]
    f = sw["freqs_hz"]

    def at(case: str, key: str, fz: float) -> float:
        return float(np.interp(fz, f, sw[case][key]))

    rows = [
        ("F_ref -> F_act bandwidth (Fig. 16 left)", f"{pp['force_bandwidth_hz']:.0f} Hz",
         f"{s['force_bandwidth_hz']:.1f} Hz"),
        ("gamma_ref -> gamma bandwidth (Fig. 16 right)", f"{pp['angle_bandwidth_hz']:.0f} Hz",
         f"{s['angle_bandwidth_hz']:.1f} Hz"),
        ("+-100 N steps: mean power (Fig. 14)", f"{pp['small_step_mean_power_W_measured']:.0f} W measured, "
         f"{pp['small_step_mean_power_W_simulated']:.0f} W simulated",
         f"{s['small_step_mean_power_W']:.1f} W (1 s after the step), {s['small_step_mean_power_W_05s']:.1f} W "
         f"(0.5 s); peak {s['small_step_peak_power_W']:.0f} W"),
        ("maximum steps: mean power (Fig. 15)", f"{pp['max_step_mean_power_W_measured'][0]:.0f}-"
         f"{pp['max_step_mean_power_W_measured'][1]:.0f} W measured, {pp['max_step_mean_power_W_simulated']:.0f} W "
         "simulated", f"{s['max_step_mean_power_W']:.0f} W (1 s), {s['max_step_mean_power_W_05s']:.0f} W (0.5 s); "
         f"peak {s['max_step_peak_power_W']:.0f} W"),
        ("l sin(alpha) -> F anti-resonance (Fig. 17 left)", f"about {pp['antiresonance_hz']:.0f} Hz",
         f"{s['antiresonance_hz']:.1f} Hz (theory sqrt(k_eff l^2 / J_w): {s['antiresonance_hz_theory']:.1f} Hz)"),
        ("flying carpet: disturbances suppressed below (Fig. 17 right)",
         f"{pp['flying_carpet_rejection_hz_sim']:.0f} Hz sim, {pp['flying_carpet_rejection_hz_setup']:.0f} Hz setup",
         f"{s['flying_carpet_rejection_hz']:.1f} Hz (-3 dB vs gamma = 0), "
         f"{s['flying_carpet_rejection_at_1hz_dB']:.0f} dB at 1 Hz"),
        ("worst-case mean power, A_max, alpha = 0, 2 Hz / 10 Hz (Fig. 7)", "friction dominates below 6 Hz",
         f"{at('alpha0', 'mean_W', 2):.0f} / {at('alpha0', 'mean_W', 10):.0f} W with friction, "
         f"{at('no_friction', 'mean_W', 2):.0f} / {at('no_friction', 'mean_W', 10):.0f} W without"),
        ("peak power, A_max, 2 Hz: alpha = -15 / 0 / +15 deg (Fig. 8)", "peak varies strongly with alpha, mean little",
         f"{at('alpha-15', 'peak_W', 2):.0f} / {at('alpha0', 'peak_W', 2):.0f} / {at('alpha+15', 'peak_W', 2):.0f} W "
         f"(mean {at('alpha-15', 'mean_W', 2):.0f} / {at('alpha0', 'mean_W', 2):.0f} / "
         f"{at('alpha+15', 'mean_W', 2):.0f} W)"),
        ("mean power at A_max / 2 / 4, 2 Hz (Fig. 9)", "drops by more than 50 % per halving",
         f"{at('alpha0', 'mean_W', 2):.0f} / {at('half', 'mean_W', 2):.0f} / {at('quarter', 'mean_W', 2):.0f} W"),
    ]
    lines = ["| quantity | paper | this reproduction |", "|---|---|---|"]
    lines += [f"| {a} | {b} | {c} |" for a, b, c in rows]
    lines.append("")
    lines.append(f"Bandwidth (force / angle) against the noise amplitude (N rms): "
                 f"{s['force_noise_rms_N']:.0f} N: {s['force_bandwidth_hz']:.1f} / {s['angle_bandwidth_hz']:.1f} Hz; "
                 f"{amp}.")
    return "\n".join(lines)


def doc_markdown(res: dict[str, Any], table: str, paper: dict[str, Any] | None) -> str:
    """The README snippet: commands, the baseline table and the paper comparison."""
    cmd = "python -m benchmarks.baselines" + (" --quick" if res["quick"] else "")
    parts = [
        "## Baselines",
        "",
        "Classical controllers for every task, as policy objects (`reset()`, then observation -> action, "
        "configured by a dataclass, run at the environment's `control_dt`) in `baselines/`: the eLPAS "
        "paper's cascade (`elpas_cascade.py`: PI current loop with anti-windup and resistance feed-forward = "
        "the env's `control_mode=\"current\"`, eqs. 10-13; lead-lag angle loop with clamped integrator, eq. 14; "
        "10 Hz low-pass + 2-D lookup at alpha = 0; Table 2 gains), its 3-D-lookup variant, the vsaUT-II "
        "decoupled controller (`vsaut2_decoupled.py`) and the quarter-car passive / skyhook controllers "
        "(`quarter_car.py`).  `baselines.metrics.evaluate_policy(env_id, policy_factory, seeds)` is the "
        "evaluation protocol shared with the RL agents.",
        "",
        f"Made with `{cmd} --json docs/baselines.json --doc docs/baselines.md --paper-summary "
        "docs/elpas_paper_summary.json` (seeds "
        f"{res['seeds']}; wall time {res['wall_s']:.0f} s).  Energy is the signed electrical energy drawn "
        "from the supply per episode; violations = episodes ended by a constraint.  The quarter car runs on its "
        "registered default: ISO 8608 class B at 20 m/s, 300 N s/m parallel damper (see `benchmarks/baselines.py` "
        "for why).",
        "",
        table,
        "",
        "![baselines](img/" + ("baselines_metrics_quick.png" if res["quick"] else "baselines_metrics.png") + ")",
        "",
    ]
    if paper is not None:
        parts += [
            "### eLPAS paper reproduction (Figs. 7-9, 14-17)",
            "",
            "Made with `python -m benchmarks.elpas_paper --out DIR` (figures copied to `docs/img/elpas_fig*.png`, "
            "summary to `docs/elpas_paper_summary.json`).  The same `ElpasCascade` object as in the table drives "
            "the force-tracking environment's task with prescribed signals (`baselines/elpas_rig.py`).",
            "",
            paper_markdown(paper),
            "",
            "Where the reproduction differs from the paper, and why:",
            "",
            "* *Bandwidths* depend on the excitation amplitude, which the paper does not give: with 10 N rms "
            "the loop is nearly linear (angle loop a little below the paper's 25 Hz, see the table); from "
            "about 50 N rms the "
            "arm hits the speed limit U_max / (K_E |N|) = 7.5 rad/s and the estimated bandwidth collapses.  The "
            "current loop (P_m = 0.1 V/N m, i.e. 0.0095 V/A) is mostly the R I_ref feed-forward, so the back-EMF "
            "adds strong damping at the arm (K_T K_E N^2 / R = 242 N m s/rad against J_r = 0.7 kg m^2).",
            "* *Step powers* are averages over a window the paper does not state; we give 1 s and 0.5 s after "
            "the step.  The small steps are friction-dominated and land near the paper's simulated 18 W; "
            "the maximum steps are speed-limited (voltage saturation) for most of the transition, as in Fig. 15.",
            "* *Anti-resonance*: it sits at sqrt(k_eff l^2 / J_w); the wishbone inertia J_w = 0.6 kg m^2 and "
            "the cone geometry are [proposed] (parameters.md), the paper's 6 Hz corresponds to J_w of about "
            "1 kg m^2 with our k_eff.  The rig's force sensor sees F_act + J_w alpha'' / (l cos alpha).",
            "* *Flying carpet*: the 3-D lookup compensates alpha through the angle loop only (the 10 Hz "
            "reference filter does not delay it), so rejection ends where the angle loop's phase lag grows (the "
            "gamma_ref -> gamma phase passes -30 deg near 10 Hz): a few Hz, between the paper's simulation (8 Hz) "
            "and its setup (3 Hz).",
            "* *Power sweeps*: the amplitude A_max(f) follows the Fig. 4 working range (eq. 9, gamma up to 85 deg "
            "inside the stops); absolute powers depend on that choice and on the [proposed] geometry, the trends "
            "(friction dominates below about 6 Hz, peak power grows with |alpha|, mean power falls by more than "
            "half per amplitude halving) are the paper's.",
            "* *Quarter car*: the task's car has a light 300 N s/m parallel damper (wheel hop), so the body "
            "damping is the eLPAS's job: the skyhook through the cascade lowers the W_k-weighted a_w below the "
            "zero policy at an energy cost.  With the 1.2 kN s/m damper of parameters.md the damper's 4-12 Hz "
            "transmission dominates a_w and even the ideal-force skyhook moved it by only about 1 %.  The zero "
            "policy equals the passive car: with no current, friction (0.5 N m at the motor, 29.5 N m at the "
            "arm) holds gamma.",
            "",
            "![Fig. 16](img/elpas_fig16_frf.png)",
            "![Figs. 14-15](img/elpas_fig14_15_steps.png)",
            "![Fig. 17](img/elpas_fig17_stiffness.png)",
            "![Figs. 7-9](img/elpas_fig07_09_power.png)",
            "",
        ]
    return "\n".join(parts)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="2 seeds, short episodes (< 2 min)")
    ap.add_argument("--json", type=Path, default=None, help="write all rows as JSON")
    ap.add_argument("--md", type=Path, default=None, help="write the markdown table")
    ap.add_argument("--plots", type=Path, default=Path("docs/img"), help="directory of the plots")
    ap.add_argument("--doc", type=Path, default=None,
                    help="write the README snippet (docs/baselines.md) with this table and --paper-summary")
    ap.add_argument("--paper-summary", type=Path, default=None,
                    help="summary.json of `python -m benchmarks.elpas_paper` for the Fig. 16 comparison in --doc")
    ap.add_argument("--from-json", type=Path, default=None,
                    help="re-render the table, plots and --doc from a previous --json file instead of running")
    a = ap.parse_args(argv)
    res = json.loads(a.from_json.read_text()) if a.from_json is not None else run(a.quick)
    table = markdown(res["rows"])
    if a.doc is not None:
        paper = json.loads(a.paper_summary.read_text()) if a.paper_summary is not None else None
        a.doc.parent.mkdir(parents=True, exist_ok=True)
        a.doc.write_text(doc_markdown(res, table, paper))
    print(table)
    print(f"wall time {res['wall_s']:.1f} s")
    for pth in plot(res, a.plots):
        print(f"wrote {pth}")
    if a.json is not None:
        a.json.parent.mkdir(parents=True, exist_ok=True)
        a.json.write_text(json.dumps(res, indent=2, default=str))
    if a.md is not None:
        a.md.parent.mkdir(parents=True, exist_ok=True)
        a.md.write_text(table + "\n")


if __name__ == "__main__":
    main()
