"""Close the loop (issue #7, item 5): identify, rebuild the environment, retune, measure on the "measured" plant.

``python -m benchmarks.identify_close_loop [--out DIR] [--seed S] [--experiment E] [--quick] [--case vsaut2|elpas]``

The case: the vsaUT-II with a drifted lever spring (``spring_stiffness_drift``: ``lever.k`` off by
+-6 ... 15 %, the range of :data:`vsa_gym.devices.vsaut2.synthetic.RANGES`; seed 1: +10.6 %).  The
decoupled position/stiffness baseline (:mod:`baselines.vsaut2_decoupled`) sets the stiffness open loop
by inverting the lever model, so a spring-rate error becomes a stiffness tracking error one for one.
``--case elpas`` runs the eLPAS force-tracking rig with a drifted cone spring (:func:`run_elpas`):
there the paper's cascade uses the spring rate only in its alpha-compensated 3-D lookup, and its force
error is dominated by the loop's lag and the imposed alpha motion, so rebuilding the lookup on the
identified model gives no gain (measured; ``docs/identification.md``).  Friction does not enter the
cascade at all, so a planted friction effect could not change the rebuilt controller either.

Steps:

1. the "measured" record: the paper's free-oscillation experiment (Fig. 10) run on the truth plant
   by the seeded generator (:func:`~vsa_gym.devices.vsaut2.synthetic.make_vsaut2_record`, AS5043
   quantisation and noise);
2. ``Identifier().fit(record)`` names the effect and fits it (test part of the record held out);
3. the identified parameter set ``Vsaut2Adapter.identified_params(theta)`` rebuilds the environment,
   ``gym.make(ENV_ID, params=identified)``; how close each simulator is to the truth plant is measured
   in closed loop (same controller, same episode seeds: RMS difference of the output angle and of
   ln K between the simulator and the truth plant);
4. the baseline tuned on the nominal model (paper gains, nominal parameters) runs on the truth plant;
5. it is retuned on the identified environment only (:func:`baselines.retune.retune_decoupled`: the
   controller rebuilt on the identified parameters, then a Nelder-Mead search of two gain
   multipliers on that environment's per-step cost over tuning seeds) and evaluated on the truth plant.
   The same search on the nominal environment is the control: it separates what tuning alone gives
   from what the identified model gives.  The controller designed on the truth itself is shown as an
   oracle (not available in practice).

Every evaluation is :func:`baselines.metrics.evaluate_policy` on held-out episode seeds
(:data:`EVAL_SEEDS`), distinct from the tuning seeds (:data:`TUNE_SEEDS`).  Writes
``close_loop.json`` and ``close_loop.md`` to ``--out`` (default ``out/identify_close_loop``).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # `python benchmarks/identify_close_loop.py` from anywhere
    sys.path.insert(0, str(ROOT))

import vsa_gym  # noqa: E402, F401  (registers the ids)
from baselines.metrics import PolicyFactory, evaluate_policy  # noqa: E402
from baselines.retune import PS_ENV, RetuneResult, decoupled_factory, retune_decoupled  # noqa: E402
from baselines.vsaut2_decoupled import VsaUT2DecoupledConfig  # noqa: E402
from vsa_gym.devices.vsaut2.adapter import Vsaut2Adapter  # noqa: E402
from vsa_gym.devices.vsaut2.params import VsaUT2Params  # noqa: E402
from vsa_gym.devices.vsaut2.synthetic import make_vsaut2_record  # noqa: E402
from vsa_gym.identify.pipeline import IdentificationResult, Identifier  # noqa: E402

ENV_ID = PS_ENV
EXPERIMENT = "free_oscillation"
EFFECT = "spring_stiffness_drift"
TUNE_SEEDS: tuple[int, ...] = tuple(range(32))  # a vector env: seeds are cheap, steps are not
EVAL_SEEDS: tuple[int, ...] = tuple(range(1000, 1016))
METRICS = ("position_rms_rad", "log_stiffness_rms", "energy_J", "return", "violations", "steps")
PAIRED = ("log_stiffness_rms", "lnK_median_abs", "position_rms_rad", "energy_J")


@dataclasses.dataclass(frozen=True)
class CloseLoopSettings:
    """Budget of one run (the defaults are the documented run; :meth:`quick` is the test's)."""

    seed: int = 1
    experiment: str = EXPERIMENT  # the record: "free_oscillation" (Fig. 10) or "torque_sweep" (Fig. 11)
    tune_seeds: tuple[int, ...] = TUNE_SEEDS
    eval_seeds: tuple[int, ...] = EVAL_SEEDS
    episode_steps: int | None = None  # evaluation episodes; None: the env's 2500 steps (5 s)
    tune_steps: int | None = None  # tuning episodes; None: the env's 2500 steps, as evaluated
    max_evals: int = 12  # Nelder-Mead budget of each gain search (0: rebuild only)
    candidates: tuple[str, ...] | None = None  # identifier catalogue (None: all the adapter offers)
    n_fit: int = 3
    control_search: bool = True  # also run the same search on the nominal env (the control)

    @classmethod
    def quick(cls, seed: int = 1) -> CloseLoopSettings:
        """A < 1 min version: three competing effects, short episodes, few seeds, no gain search."""
        return cls(seed=seed, tune_seeds=(0, 1), eval_seeds=(1000, 1001, 1002, 1003), episode_steps=1000,
                   tune_steps=1000, max_evals=0, n_fit=2, control_search=False,
                   candidates=("spring_stiffness_drift", "inertia_error", "coulomb_friction"))


# ----------------------------------------------------------------------------- identification
def identify(settings: CloseLoopSettings) -> tuple[IdentificationResult, dict[str, Any], dict[str, VsaUT2Params]]:
    """Steps 1-3: the measured record, the identification, and the nominal / truth / identified parameter sets."""
    rec, truth = make_vsaut2_record(settings.seed, settings.experiment, EFFECT)
    ident = Identifier(n_fit=settings.n_fit, candidates=settings.candidates).fit(rec)
    res = ident.result_
    assert res is not None
    ad = res.adapter
    if not isinstance(ad, Vsaut2Adapter):
        raise TypeError(f"expected a vsaUT-II adapter, got {type(ad).__name__}")
    params = {"nominal": ad.params, "truth": ad.identified_params(truth["params"]),
              "identified": ad.identified_params(res.final.theta())}
    return res, truth, params


def plant_gap(params: dict[str, VsaUT2Params], factory: PolicyFactory, seeds: Sequence[int],
              episode_steps: int | None) -> dict[str, dict[str, float]]:
    """How far each simulator is from the truth plant in closed loop.

    The same controller runs the same episode seeds (same references and disturbances) on each
    simulator and on the truth plant; returned per simulator: RMS over the steps both episodes are
    alive of the difference of the output angle ``r`` (rad) and of ``ln K``.
    """
    traces = {}
    for name, p in params.items():
        row = evaluate_policy(ENV_ID, factory, seeds, episode_steps=episode_steps, env_kwargs={"params": p},
                              return_traces=True)
        traces[name] = row["traces"]
    out = {}
    for name in params:
        if name == "truth":
            continue
        gap = {}
        for key, label in (("position_error", "r_rad"), ("log_stiffness_error", "lnK")):
            d = traces[name][key] - traces["truth"][key]
            gap[label] = float(np.sqrt(np.nanmean(d**2)))
        out[name] = gap
    return out


# ----------------------------------------------------------------------------- controllers
@dataclasses.dataclass
class Controller:
    """A controller of the comparison: its label, how it was obtained, and its policy factory."""

    key: str
    label: str
    factory: PolicyFactory
    retune: RetuneResult | None = None


def controllers(params: dict[str, VsaUT2Params], settings: CloseLoopSettings,
                log: Callable[[str], None]) -> list[Controller]:
    """Step 4-5: nominal-tuned, (control) retuned on nominal, rebuilt / retuned on identified, oracle."""
    paper = VsaUT2DecoupledConfig()
    out = [Controller("nominal_tuned", "tuned on nominal (paper gains, nominal model)",
                      decoupled_factory(paper, params["nominal"]))]
    if settings.control_search and settings.max_evals > 0:
        log("gain search on the NOMINAL env (control) ...")
        r = retune_decoupled(params["nominal"], settings.tune_seeds, max_evals=settings.max_evals,
                             episode_steps=settings.tune_steps, log=log)
        out.append(Controller("nominal_retuned", "retuned on nominal (same search, nominal env)",
                              decoupled_factory(r.config, params["nominal"]), r))
    out.append(Controller("identified_rebuilt", "rebuilt on identified (paper gains, identified model)",
                          decoupled_factory(paper, params["identified"])))
    if settings.max_evals > 0:
        log("gain search on the IDENTIFIED env ...")
        r = retune_decoupled(params["identified"], settings.tune_seeds, max_evals=settings.max_evals,
                             episode_steps=settings.tune_steps, log=log)
        out.append(Controller("identified_retuned", "retuned on identified (rebuild + search, identified env)",
                              decoupled_factory(r.config, params["identified"]), r))
    out.append(Controller("oracle", "oracle: truth model, paper gains (not available in practice)",
                          decoupled_factory(paper, params["truth"])))
    return out


def evaluate(ctrl: Controller, plant: VsaUT2Params, settings: CloseLoopSettings) -> dict[str, Any]:
    """Metrics of one controller on one plant over the held-out seeds (means; ``per_episode`` kept)."""
    row = evaluate_policy(ENV_ID, ctrl.factory, settings.eval_seeds, episode_steps=settings.episode_steps,
                          env_kwargs={"params": plant}, return_traces=True)
    out = {k: float(row[k]) for k in METRICS}
    per = dict(row["per_episode"])
    # the RMS is dominated by the transients after each reference step; the median over the episode's
    # steps of |error| is the steady error a model mismatch leaves (a spring-rate error: a ln K bias)
    for key, trace in (("lnK_median_abs", "log_stiffness_error"), ("position_median_abs_rad", "position_error")):
        per[key] = np.nanmedian(np.abs(row["traces"][trace]), axis=1).tolist()
        out[key] = float(np.mean(per[key]))
    out["per_episode"] = per
    return out


def paired(a: dict[str, Any], b: dict[str, Any], key: str) -> dict[str, float]:
    """Mean and standard error over the episodes of ``b[key] - a[key]`` (same seeds, paired)."""
    d = np.asarray(b["per_episode"][key]) - np.asarray(a["per_episode"][key])
    se = float(d.std(ddof=1) / np.sqrt(d.size)) if d.size > 1 else float("nan")
    return {"mean": float(d.mean()), "se": se, "better_in": int(np.sum(d < 0)), "episodes": int(d.size)}


# ----------------------------------------------------------------------------- run
def run(settings: CloseLoopSettings,
        log: Callable[[str], None] = print) -> tuple[dict[str, Any], dict[str, VsaUT2Params]]:
    """The whole case; returns the JSON-able result and the nominal / truth / identified parameter sets."""
    t0 = time.perf_counter()
    res, truth, params = identify(settings)
    t_id = time.perf_counter() - t0
    for line in res.statements():
        log(f"identified: {line}")
    # step 3: the identified parameters rebuild the environment
    env = gym.make(ENV_ID, params=params["identified"])
    env.reset(seed=settings.eval_seeds[0])
    k_env = float(env.unwrapped.task.base_rows[0].lever.k)
    env.close()
    ctrls = controllers(params, settings, log)
    nominal_tuned = ctrls[0]
    gap = plant_gap(params, nominal_tuned.factory, settings.eval_seeds, settings.episode_steps)
    log(f"closed-loop gap to the truth plant: {gap}")
    results: dict[str, dict[str, Any]] = {"truth": {}, "nominal": {}, "identified": {}}
    for c in ctrls:
        results["truth"][c.key] = evaluate(c, params["truth"], settings)
        log(f"truth plant  {c.label}: " + ", ".join(f"{k} {results['truth'][c.key][k]:.4g}" for k in
                                                         (*METRICS, "lnK_median_abs")))
    context = [c for c in ctrls if c.key in ("nominal_tuned", "nominal_retuned", "identified_rebuilt",
                                             "identified_retuned")]
    for plant in ("nominal", "identified"):
        for c in context:
            results[plant][c.key] = evaluate(c, params[plant], settings)
    best_id = "identified_retuned" if "identified_retuned" in results["truth"] else "identified_rebuilt"
    tr = results["truth"]
    out = {
        "case": {"env_id": ENV_ID, "experiment": settings.experiment, "effect": EFFECT, "record_seed": settings.seed,
                 "planted": truth["params"]},
        "settings": dataclasses.asdict(settings),
        "identification": {"statements": res.statements(), "effects": res.effects,
                           "metrics_before": res.metrics_before, "metrics_after": res.metrics_after,
                           "seconds": t_id},
        "params": {k: {"lever.k": float(p.lever.k), "I_o": float(p.I_o), "c_o": float(p.c_o),
                       "effects.F_c_o": float(p.effects.F_c_o)} for k, p in params.items()},
        "env_rebuilt_lever_k": k_env,
        "plant_gap": gap,
        "controllers": {c.key: {"label": c.label, "retune": c.retune.summary() if c.retune else None} for c in ctrls},
        "results": {plant: {k: {m: v for m, v in r.items()} for k, r in rows.items()} for plant, rows in
                    results.items()},
        "paired_on_truth": {f"{k} - nominal_tuned": {m: paired(tr["nominal_tuned"], tr[k], m) for m in PAIRED}
                            for k in ("identified_rebuilt", "identified_retuned", "oracle") if k in tr},
        "seconds": time.perf_counter() - t0,
    }
    if "nominal_retuned" in tr:
        out["paired_on_truth"][f"{best_id} - nominal_retuned"] = {
            m: paired(tr["nominal_retuned"], tr[best_id], m) for m in PAIRED}
    return out, params


HEADER = ("| controller | position RMS (rad) | ln K RMS | median abs ln K error | energy (J) | return | "
          "episodes ended early |")


def markdown(out: dict[str, Any], command: str) -> str:
    """The tables of the docs (``close_loop.md``)."""
    case, ctrls = out["case"], out["controllers"]
    drift = case["planted"].get("spring_stiffness_drift.drift")
    experiment = case["experiment"].replace("_", " ")
    st = out["identification"]["statements"]
    named = "; ".join(st[:-1]) if out["identification"]["effects"] else st[0]
    lines = [f"Command: `{command}` ({out['seconds']:.0f} s).", "",
             f"Truth plant: vsaUT-II, lever spring rate `lever.k` drifted by {100 * drift:+.1f} % "
             f"(record seed {case['record_seed']}).  Identified from the {experiment} record: {named} "
             f"({out['identification']['seconds']:.0f} s).", "",
             "| simulator | lever.k (N/m) | closed-loop gap to truth: r RMS (rad) | ln K RMS |",
             "|---|---|---|---|"]
    for name in ("nominal", "identified"):
        g = out["plant_gap"][name]
        lines.append(f"| {name} | {out['params'][name]['lever.k']:.1f} | {g['r_rad']:.4f} | {g['lnK']:.4f} |")
    lines.append(f"| truth | {out['params']['truth']['lever.k']:.1f} | 0 | 0 |")
    n_eval = len(out["settings"]["eval_seeds"])
    tune_len = f"{out['settings']['tune_steps']}-step" if out["settings"]["tune_steps"] else "full"
    lines += ["", f"On the truth plant (\"measured\"), {n_eval} held-out episode seeds "
              f"{out['settings']['eval_seeds'][0]}-{out['settings']['eval_seeds'][-1]}; gain searches on seeds "
              f"{out['settings']['tune_seeds'][0]}-{out['settings']['tune_seeds'][-1]} "
              f"({tune_len} episodes) of the named env only:", "",
              HEADER, "|---|---|---|---|---|---|---|"]

    def row(plant: str, key: str) -> str:
        r = out["results"][plant][key]
        v = int(round(r["violations"]))
        return (f"| {ctrls[key]['label']} | {r['position_rms_rad']:.4f} | {r['log_stiffness_rms']:.4f} | "
                f"{r['lnK_median_abs']:.4f} | {r['energy_J']:.1f} | {r['return']:.1f} | {v} / {n_eval} |")

    lines += [row("truth", k) for k in out["results"]["truth"]]
    for plant in ("nominal", "identified"):
        lines += ["", f"For context, on the {plant} simulator:", "", HEADER, "|---|---|---|---|---|---|---|"]
        lines += [row(plant, k) for k in out["results"][plant]]
    lines += ["", "Paired differences on the truth plant (mean +- s.e. over the episodes; negative = better):", ""]
    for name, d in out["paired_on_truth"].items():
        parts = [f"{m} {v['mean']:+.4g} +- {v['se']:.2g} (better in {v['better_in']}/{v['episodes']})"
                 for m, v in d.items()]
        lines.append(f"- {name}: " + "; ".join(parts))
    for key, c in ctrls.items():
        if c["retune"]:
            s = c["retune"]
            lines.append(f"- {key}: gain multipliers exp({s['log_multipliers'][0]:+.2f}) pivot, "
                         f"exp({s['log_multipliers'][1]:+.2f}) frame; tuning objective {s['objective_start']:.4f} -> "
                         f"{s['objective']:.4f} in {s['evaluations']} evaluations ({s['seconds']:.0f} s)")
    return "\n".join(lines) + "\n"


# ----------------------------------------------------------------------------- the eLPAS case (no gain)
ELPAS_ENV = "vsa_gym/ELPAS-ForceTracking-v0"
ELPAS_EVAL_SEEDS: tuple[int, ...] = tuple(range(1000, 1008))
ELPAS_STEPS = 2000  # 2 s episodes (the env's limit is 5 s; the 10 kHz current loop makes each step costly)


def cascade_factory(config: Any, design: Any) -> PolicyFactory:
    """The paper's eLPAS cascade designed with ``design`` (:class:`ElpasParams`), not the env's parameters."""
    from baselines.elpas_cascade import ElpasCascade

    def make(env: Any) -> Any:
        task = env.unwrapped.task
        return ElpasCascade(dataclasses.replace(config, dt=float(task.control_dt)), design,
                            [c.name for c in task.obs_channels])

    return make


def run_elpas(seed: int = 2, log: Callable[[str], None] = print, eval_seeds: Sequence[int] = ELPAS_EVAL_SEEDS,
              episode_steps: int = ELPAS_STEPS) -> dict[str, Any]:
    """The same steps on the eLPAS force-tracking rig with a drifted cone spring (``C_a``).

    Identification as in ``tests/identify/test_elpas_effects.py`` (1.5 s sine force test, step test
    held out, ``Identifier(n_fit=2, max_nfev=15)``).  The cascade uses the model only through its
    lookup ``gamma_ref(F_ref[, alpha])``; at ``alpha = 0`` ``C_a`` does not enter it, so only the
    alpha-compensated 3-D lookup can use the identified spring rate: it is rebuilt on the nominal,
    identified and truth (oracle) parameters and run on the truth rig with the paper's 2-D cascade
    for reference.  No gain search.
    """
    from baselines.elpas_cascade import ElpasCascadeConfig
    from vsa_gym.devices.elpas.adapter import ElpasAdapter
    from vsa_gym.devices.elpas.synthetic import make_elpas_record

    t0 = time.perf_counter()
    rec, truth = make_elpas_record(seed, "spring_stiffness_drift", "sine", duration=1.5)
    test, _ = make_elpas_record(seed + 1000, "spring_stiffness_drift", "step", duration=1.5, truth=truth["params"])
    res = Identifier(n_fit=2, max_nfev=15).fit(rec, test).result_
    assert res is not None
    ad = res.adapter
    if not isinstance(ad, ElpasAdapter):
        raise TypeError(f"expected an eLPAS adapter, got {type(ad).__name__}")
    t_id = time.perf_counter() - t0
    for line in res.statements():
        log(f"identified: {line}")
    params = {"nominal": ad.nominal, "truth": ad.identified_params(truth["params"]),
              "identified": ad.identified_params(res.final.theta())}
    kw = {"control_mode": "current"}
    paper = ElpasCascadeConfig()
    comp = ElpasCascadeConfig(alpha_compensation=True)
    ctrls = {"paper_2d": ("paper cascade, 2-D lookup (C_a does not enter it)", cascade_factory(paper,
                                                                                               params["nominal"])),
             "comp_nominal": ("3-D lookup built on nominal", cascade_factory(comp, params["nominal"])),
             "comp_identified": ("3-D lookup rebuilt on identified", cascade_factory(comp, params["identified"])),
             "comp_oracle": ("3-D lookup on the truth (oracle)", cascade_factory(comp, params["truth"]))}
    traces, results = {}, {}
    for name in ("truth", "nominal", "identified"):
        row = evaluate_policy(ELPAS_ENV, ctrls["paper_2d"][1], eval_seeds, episode_steps=episode_steps,
                              env_kwargs={**kw, "params": params[name]}, return_traces=True)
        traces[name] = row["traces"]["force_error"]
        if name == "truth":
            results["paper_2d"] = row
    gap = {n: float(np.sqrt(np.nanmean((traces[n] - traces["truth"]) ** 2))) for n in ("nominal", "identified")}
    log(f"closed-loop force gap to the truth rig (N): {gap}")
    for key in ("comp_nominal", "comp_identified", "comp_oracle"):
        results[key] = evaluate_policy(ELPAS_ENV, ctrls[key][1], eval_seeds, episode_steps=episode_steps,
                                       env_kwargs={**kw, "params": params["truth"]})
    keys = ("force_rms_N", "energy_J", "return", "violations")
    table = {k: {"label": ctrls[k][0], **{m: float(r[m]) for m in keys}, "per_episode": r["per_episode"]}
             for k, r in results.items()}
    for r in table.values():
        log(f"truth rig  {r['label']}: " + ", ".join(f"{m} {r[m]:.4g}" for m in keys))
    return {"case": {"env_id": ELPAS_ENV, "effect": "spring_stiffness_drift", "record_seed": seed,
                     "planted": truth["params"]},
            "identification": {"statements": res.statements(), "effects": res.effects, "seconds": t_id},
            "params": {k: {"cone.C_a": float(p.cone.C_a)} for k, p in params.items()},
            "plant_gap_force_N": gap, "eval_seeds": list(eval_seeds), "episode_steps": episode_steps,
            "results": table,
            "paired_on_truth": {"comp_identified - comp_nominal": {
                m: paired(table["comp_nominal"], table["comp_identified"], m) for m in ("force_rms_N", "energy_J")}},
            "seconds": time.perf_counter() - t0}


def markdown_elpas(out: dict[str, Any], command: str) -> str:
    """The eLPAS table (``close_loop_elpas.md``)."""
    case = out["case"]
    drift = case["planted"]["spring_stiffness_drift.drift"]
    n = len(out["eval_seeds"])
    lines = [f"Command: `{command}` ({out['seconds']:.0f} s).", "",
             f"Truth rig: eLPAS cone spring rate `C_a` drifted by {100 * drift:+.1f} % (record seed "
             f"{case['record_seed']}).  Identified: {out['identification']['statements'][0]}.  Closed-loop force gap "
             f"to the truth rig (paper cascade, same seeds): nominal {out['plant_gap_force_N']['nominal']:.1f} N, "
             f"identified {out['plant_gap_force_N']['identified']:.1f} N.", "",
             f"On the truth rig (`{case['env_id']}`, current mode), {n} held-out episode seeds of "
             f"{out['episode_steps']} steps:", "",
             "| controller | force RMS (N) | energy (J) | return | episodes ended early |", "|---|---|---|---|---|"]
    for r in out["results"].values():
        lines.append(f"| {r['label']} | {r['force_rms_N']:.1f} | {r['energy_J']:.1f} | {r['return']:.1f} | "
                     f"{int(round(r['violations']))} / {n} |")
    for name, d in out["paired_on_truth"].items():
        lines.append("")
        lines.append(f"Paired, {name}: " + "; ".join(
            f"{m} {v['mean']:+.4g} +- {v['se']:.2g} (better in {v['better_in']}/{v['episodes']})"
            for m, v in d.items()))
    return "\n".join(lines) + "\n"


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="out/identify_close_loop", help="output folder (JSON + markdown)")
    ap.add_argument("--seed", type=int, default=None,
                    help="seed of the measured record, i.e. of the planted drift (default 1; eLPAS: 2)")
    ap.add_argument("--quick", action="store_true", help="the test's < 1 min version (no gain search)")
    ap.add_argument("--experiment", choices=("free_oscillation", "torque_sweep"), default=EXPERIMENT,
                    help="vsaUT-II record the drift is identified from (Fig. 10 or Fig. 11)")
    ap.add_argument("--case", choices=("vsaut2", "elpas"), default="vsaut2",
                    help="vsaut2: the documented case; elpas: the force-tracking rig (no gain, see run_elpas)")
    args = ap.parse_args(argv)
    d = Path(args.out)
    d.mkdir(parents=True, exist_ok=True)
    if args.case == "elpas":
        seed = 2 if args.seed is None else args.seed
        out = run_elpas(seed)
        cmd = "python -m benchmarks.identify_close_loop --case elpas" + (f" --seed {seed}" if seed != 2 else "")
        md, stem = markdown_elpas(out, cmd), "close_loop_elpas"
    else:
        seed = 1 if args.seed is None else args.seed
        settings = CloseLoopSettings.quick(seed) if args.quick else CloseLoopSettings(seed=seed)
        settings = dataclasses.replace(settings, experiment=args.experiment)
        out, _ = run(settings)
        cmd = "python -m benchmarks.identify_close_loop" + (f" --seed {seed}" if seed != 1 else "") + \
            (f" --experiment {args.experiment}" if args.experiment != EXPERIMENT else "") + \
            (" --quick" if args.quick else "")
        md, stem = markdown(out, cmd), "close_loop"
    (d / f"{stem}.json").write_text(json.dumps(out, indent=1, default=float))
    (d / f"{stem}.md").write_text(md)
    print(md)
    print(f"wrote {d / (stem + '.json')} and {d / (stem + '.md')}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
