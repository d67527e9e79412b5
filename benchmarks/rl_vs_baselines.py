"""Learned agents against the baselines, on the same held-out episodes, with the same metrics.

::

    python -m benchmarks.rl_vs_baselines --timesteps 100000 --seeds 0 1 2 --episodes 8

For each environment: trains (or loads, when a finished run of the same env/algo/seed/timesteps
is in ``--log-folder``) one agent per seed through :mod:`agents.sweep` (Ray), evaluates every
agent and every baseline with :func:`baselines.metrics.evaluate_policy` on the seeds
``METRIC_SEED_BASE + k`` (k < ``--episodes``, never used in training), and writes

* ``docs/agents_results.json`` -- every number (per agent seed, per baseline episode);
* the table between the ``rl_vs_baselines`` markers in ``docs/agents.md``: mean and 95 %
  interval of the tracking metric, electrical energy, comfort (quarter car) and violations;
  for agents the interval is over the training seeds (Student t on the per-seed means over the
  episodes); the deterministic baselines get the mean over the same episodes; plus the CPU minutes
  of training;
* ``docs/img/pareto_<env>.png`` -- tracking metric against electrical energy (lower-left is better).

Baselines (from :mod:`baselines`): the paper's cascade (force tracking), passive hold and
skyhook through the cascade (quarter car; ``--skyhook-gains`` adds the skyhook at other damping
gains ``c_sky``, its comfort-energy trade-off), the decoupled controller (vsaUT-II position /
stiffness), the throw baselines (a) fixed stiffness and (b) optimal control, replayed from
``docs/throw_baselines.json`` (``python -m benchmarks.throw_baselines``), and, everywhere, the zero action.

Every return in the table is under the environment's **default** reward: an agent trained with
other reward weights (``env_kwargs`` of its hyperparameters, e.g. a higher ``w_energy``) is
evaluated without them (:func:`agents.evaluate.evaluate_agent`, ``reward="default"``) and its row
names the training weights.  A finished run in ``--log-folder`` is reused only when its
``config.yml`` equals the current hyperparameters (otherwise the agent is trained again).
"""

from __future__ import annotations

import argparse
import re
import sys
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from agents.common import METRIC_SEED_BASE, read_json, write_json

REPO = Path(__file__).resolve().parents[1]
ENVS = ("vsa_gym/ELPAS-ForceTracking-v0", "vsa_gym/ELPAS-QuarterCar-v0", "vsa_gym/VsaUT2-PositionStiffness-v0",
        "vsa_gym/VsaUT2-Throw-v0")
THROW_BASELINES = REPO / "docs" / "throw_baselines.json"  # the throw baselines' schedules (benchmarks.throw_baselines)
MARK_BEGIN = "<!-- rl_vs_baselines:begin -->"
MARK_END = "<!-- rl_vs_baselines:end -->"
# columns of the table: (metric key, header, format)
COLUMNS: dict[str, list[tuple[str, str, str]]] = {
    "vsa_gym/ELPAS-ForceTracking-v0": [("force_rms_N", "force RMS (N)", "{:.1f}")],
    "vsa_gym/ELPAS-QuarterCar-v0": [("comfort_aw_rms", "comfort a_w RMS (m/s²)", "{:.3f}"),
                                    ("tyre_load_rms", "tyre load RMS (-)", "{:.3f}")],
    "vsa_gym/VsaUT2-PositionStiffness-v0": [("position_rms_rad", "position RMS (rad)", "{:.4f}"),
                                            ("log_stiffness_rms", "ln K RMS (-)", "{:.3f}")],
    "vsa_gym/VsaUT2-Throw-v0": [("return", "release speed = return (rad/s)", "{:.3f}")],
}
COMMON = [("energy_J", "energy (J)", "{:.2f}"), ("peak_power_W", "peak power (W)", "{:.0f}"),
          ("violations", "episodes ended by a violation", "{:.2f}"), ("steps", "mean episode steps", "{:.0f}"),
          ("return", "return", "{:.1f}")]


def skyhook_name(c_sky: float) -> str:
    """Row name of the skyhook at gain ``c_sky`` (the default gain keeps the plain name)."""
    from baselines.quarter_car import SkyhookConfig

    return "skyhook cascade" if c_sky == SkyhookConfig.c_sky else f"skyhook cascade, c_sky = {c_sky:g} N s/m"


def baseline_factories(env_id: str, skyhook_gains: Sequence[float] = ()
                       ) -> dict[str, tuple[Callable[[Any], Any], dict[str, Any]]]:
    """``name -> (policy_factory, env_kwargs)`` of the baselines of ``env_id`` (``skyhook_gains``: extra
    skyhook rows at these damping gains, N s/m, quarter car only)."""
    from baselines.metrics import zero_policy_factory

    out: dict[str, tuple[Callable[[Any], Any], dict[str, Any]]] = {"zero action": (zero_policy_factory, {})}
    if env_id == "vsa_gym/ELPAS-ForceTracking-v0":
        from baselines.elpas_cascade import elpas_cascade_factory

        out["cascade (paper)"] = (elpas_cascade_factory(), {"control_mode": "current"})
    elif env_id == "vsa_gym/ELPAS-QuarterCar-v0":
        from baselines.quarter_car import SkyhookConfig, passive_factory, skyhook_factory

        out["passive hold"] = (passive_factory(), {"control_mode": "current"})
        out["skyhook cascade"] = (skyhook_factory(), {"control_mode": "current"})
        for c in sorted(set(float(g) for g in skyhook_gains)):
            if c < 0:
                raise ValueError(f"skyhook gains must be >= 0 N s/m, got {c}")
            out[skyhook_name(c)] = (skyhook_factory(SkyhookConfig(c_sky=c)), {"control_mode": "current"})
    elif env_id == "vsa_gym/VsaUT2-PositionStiffness-v0":
        from baselines.vsaut2_decoupled import vsaut2_decoupled_factory

        out["decoupled"] = (vsaut2_decoupled_factory(), {})
    elif env_id == "vsa_gym/VsaUT2-Throw-v0":
        from baselines.vsaut2_throw import SCHEDULE_LABELS, schedule_factory

        record = read_json(THROW_BASELINES, None)
        if record is None:
            raise SystemExit(f"{THROW_BASELINES} not found: run python -m benchmarks.throw_baselines first")
        for key, label in SCHEDULE_LABELS.items():
            out[f"throw {label} (its own start stiffness)"] = schedule_factory(record[key])
    return out


def evaluate_baselines(env_id: str, episodes: int, cache: dict[str, Any], skyhook_gains: Sequence[float] = (),
                       seed_base: int = METRIC_SEED_BASE, env_kwargs: Mapping[str, Any] | None = None,
                       episode_steps: int | None = None) -> dict[str, list[dict[str, Any]]]:
    """Metrics of every baseline over the episodes ``seed_base + k`` (one batched ``evaluate_policy`` call each;
    ``env_kwargs`` on top of each baseline's own arguments).

    The baselines are deterministic controllers; the row is the mean over the episodes (batched
    evaluation returns means only, so no interval is given for them).
    """
    from baselines.metrics import evaluate_policy

    seeds = [seed_base + k for k in range(episodes)]
    extra = dict(env_kwargs or {})
    out: dict[str, list[dict[str, Any]]] = {}
    for name, (factory, kw) in baseline_factories(env_id, skyhook_gains).items():
        key = f"{env_id}|{name}|{seeds[0]}|{episodes}" + (f"|{extra}|{episode_steps}" if extra or episode_steps else "")
        if key not in cache:
            cache[key] = evaluate_policy(env_id, factory, seeds, episode_steps=episode_steps,
                                         env_kwargs={**kw, **extra} or None)
        out[name] = [cache[key]]
    return out


def interval(values: Sequence[float]) -> tuple[float, float, float]:
    """Mean and two-sided 95 % Student-t interval of the mean (degenerate for one value)."""
    from scipy import stats

    v = np.asarray(values, dtype=np.float64)
    m = float(v.mean())
    if v.size < 2:
        return m, m, m
    h = float(stats.t.ppf(0.975, v.size - 1) * v.std(ddof=1) / np.sqrt(v.size))
    return m, m - h, m + h


def _cell(values: Sequence[float], fmt: str) -> str:
    m, lo, hi = interval(values)
    if lo == hi:
        return fmt.format(m)
    return f"{fmt.format(m)} [{fmt.format(lo)}, {fmt.format(hi)}]"


def table(env_id: str, agents: dict[str, list[dict[str, Any]]], base: dict[str, list[dict[str, Any]]]) -> str:
    """Markdown table of one environment (agents: per-seed rows with ``cpu_min``; baselines: per episode)."""
    own = {k for k, _, _ in COLUMNS[env_id]}
    cols = COLUMNS[env_id] + [c for c in COMMON if c[0] not in own]
    head = "| policy | n | " + " | ".join(h for _, h, _ in cols) + " | CPU min (train) |"
    lines = [head, "|" + "---|" * (len(cols) + 3)]
    for name, rows in base.items():
        cells = [_cell([r[k] for r in rows], f) for k, _, f in cols]
        lines.append(f"| {name} | {rows[0]['episodes']} ep. (mean) | " + " | ".join(cells) + " | - |")
    for name, rows in agents.items():
        cells = [_cell([r["metrics"][k] for r in rows], f) for k, _, f in cols]
        cpu = _cell([r["cpu_min"] for r in rows], "{:.1f}")
        lines.append(f"| **{name}** | {len(rows)} seeds | " + " | ".join(cells) + f" | {cpu} |")
    return "\n".join(lines)


def pareto_plot(env_id: str, agents: dict[str, list[dict[str, Any]]], base: dict[str, list[dict[str, Any]]],
                out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from baselines.metrics import PRIMARY_METRIC

    key = PRIMARY_METRIC[env_id]
    fig, ax = plt.subplots(figsize=(6.4, 5.4), dpi=110)
    markers = iter("sD^vP*Xhp<>d8" * 3)
    family = sorted(((float(np.mean([r["energy_J"] for r in rows])), float(np.mean([r[key] for r in rows])))
                     for name, rows in base.items() if name.startswith("skyhook cascade")))
    if len(family) > 1:
        ax.plot(*zip(*family, strict=True), ls="--", lw=1, color="0.5", zorder=0, label="skyhook over its gain c_sky")
    for name, rows in base.items():
        e, y = [r["energy_J"] for r in rows], [r[key] for r in rows]
        em, elo, ehi = interval(e)
        ym, ylo, yhi = interval(y)
        ax.errorbar(em, ym, xerr=[[em - elo], [ehi - em]], yerr=[[ym - ylo], [yhi - ym]], fmt=next(markers),
                    ms=8, capsize=3, label=f"{name} (mean over the episodes)")
    for (name, rows), color in zip(agents.items(), ("tab:red", "tab:purple", "tab:brown"), strict=False):
        e, y = [r["metrics"]["energy_J"] for r in rows], [r["metrics"][key] for r in rows]
        ax.scatter(e, y, s=18, alpha=0.6, color=color)
        em, elo, ehi = interval(e)
        ym, ylo, yhi = interval(y)
        ax.errorbar(em, ym, xerr=[[em - elo], [ehi - em]], yerr=[[ym - ylo], [yhi - ym]], fmt="o", color=color,
                    ms=9, capsize=3, label=f"{name} (mean, 95% CI over seeds; dots: seeds)")
    ax.set_xlabel("electrical energy per episode (J)")
    ax.set_ylabel(key + (" (higher is better)" if key == "return" else " (lower is better)"))
    ax.set_title(env_id.split("/")[1])
    ax.grid(alpha=0.3)
    ax.legend(fontsize=6.5, loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=1)
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out)
    plt.close(fig)


def update_doc(doc: Path, text: str) -> None:
    """Replace the marked section of ``doc`` (appended when the markers are missing)."""
    block = f"{MARK_BEGIN}\n{text}\n{MARK_END}"
    old = doc.read_text() if doc.exists() else ""
    if MARK_BEGIN in old and MARK_END in old:
        new = re.sub(re.escape(MARK_BEGIN) + r".*?" + re.escape(MARK_END), lambda _: block, old, flags=re.S)
    else:
        new = old + ("\n" if old else "") + block + "\n"
    doc.write_text(new)


RESIDUAL_HYPERPARAMS = REPO / "agents" / "hyperparams" / "ppo_residual.yml"
SELECTION_KWARGS: dict[str, dict[str, Any]] = {
    "vsa_gym/ELPAS-ForceTracking-v0": {"failure_rate": 2.0},
    "vsa_gym/ELPAS-QuarterCar-v0": {"failure_rate": 0.3},
    "vsa_gym/VsaUT2-PositionStiffness-v0": {"failure_rate": None},
}
"""Arguments of the periodic-evaluation env (``--select best``): on the eLPAS tasks a failure also costs each
step it skips, so a checkpoint that ends validation episodes early cannot be chosen for collecting less negative
reward.  Force tracking: about twice what the zero action pays per step.  Quarter car: what the passive car pays
per step (0.3): two of the 8 validation roads lift the tyre off under every policy, the passive car and the
skyhook included, and a larger charge made the checkpoint that lasted longest on those two roads win over every
comfort difference (docs/agents.md, "Quarter car: selection and a longer horizon").  The vsaUT-II position task
charges a failure by default (about 129 per skipped step); ``None`` restores that default where the agent trained
with a smaller charge (``ppo.yml``).  Training keeps each entry's own ``env_kwargs``."""


def training_reward(algo: str, env_id: str, hyperparams: str | Path | None = None) -> dict[str, Any]:
    """Reward-only ``env_kwargs`` (other reward weights than the environment's) in the hyperparameters."""
    from agents.common import eval_zoo_expr, read_hyperparams
    from agents.evaluate import split_reward_kwargs

    kw = read_hyperparams(algo, env_id, hyperparams).get("env_kwargs") or {}
    return split_reward_kwargs(env_id, eval_zoo_expr(kw) if isinstance(kw, str) else dict(kw))[1]


def wrapper_note(algo: str, env_id: str, hyperparams: str | Path | None = None) -> str:
    """``"; observes the leaky integral of body_accel"`` when the hyperparameters add observation features,
    ``"; decides every 25 control steps"`` when they hold the agent's actions (:mod:`agents.hold`), and what a
    ``callback`` entry changes: ``"; warm-started by cloning decoupled"`` (:mod:`agents.warm_start`: the agent
    starts as the baseline's imitation) and ``"; exploration noise planned"`` (:mod:`agents.exploration`);
    ``"; sees the last 4 observations"`` for rl-zoo3's ``frame_stack``."""
    from agents.common import class_entries, frame_stack_of, read_hyperparams
    from agents.features import feature_config
    from agents.hold import hold_steps

    hp = read_hyperparams(algo, env_id, hyperparams)
    wrappers = hp.get("vec_env_wrapper")
    cfg, steps = feature_config(wrappers), hold_steps(wrappers)
    note = "" if cfg is None else f"; observes the leaky integral of {', '.join(cfg.get('channels', ['body_accel']))}"
    note += "" if steps is None else f"; decides every {steps} control steps"
    n_stack = frame_stack_of(hp.get("frame_stack"))
    note += "" if n_stack == 1 else f"; sees the last {n_stack} observations"
    for path, kwargs in class_entries(hp.get("callback"), "callback"):
        if path == "agents.warm_start.BehaviourCloningWarmStart":
            note += f"; warm-started by cloning {kwargs.get('baseline', 'decoupled')}"
        elif path == "agents.exploration.LogStdSchedule":
            note += f"; exploration noise planned (log std {kwargs.get('start', -1.5)} to {kwargs.get('end', -3.0)})"
    return note


def reward_note(reward_kw: dict[str, Any]) -> str:
    """``"; trained with w_energy = 0.01"`` (empty for the default reward)."""
    return "".join(f"; trained with {k} = {v}" for k, v in sorted(reward_kw.items()))


def mark_stale(trials: list[dict[str, Any]]) -> list[str]:
    """Set ``retrain`` on trials whose finished run in the log folder was trained with other hyperparameters
    than the current file (its ``config.yml`` differs); returns those runs' directories."""
    import yaml

    from agents.common import env_name, read_hyperparams, read_yaml
    from agents.sweep import finished_run, selection_settings

    stale = []
    for t in trials:
        info = finished_run(t["log_folder"], t["env_id"], t["algo"], t["seed"], t.get("timesteps"),
                            selection_settings(t))
        if info is None:
            continue
        cfg = Path(info["save_path"]) / env_name(t["env_id"]) / "config.yml"
        want = yaml.safe_load(yaml.dump(dict(sorted(read_hyperparams(t["algo"], t["env_id"],
                                                                     t.get("hyperparams")).items()))))
        if not cfg.exists() or read_yaml(cfg) != want:  # ours or rl-zoo3's (OrderedDict) config.yml
            t["retrain"] = True
            stale.append(str(info["save_path"]))
    return stale


def residual_envs() -> dict[str, str]:
    """``env_id -> baseline`` of the residual entries in ``agents/hyperparams/ppo_residual.yml``."""
    from agents.common import read_yaml
    from agents.residual import residual_config

    table_ = read_yaml(RESIDUAL_HYPERPARAMS)
    return {env_id: str((residual_config(hp.get("vec_env_wrapper")) or {}).get("baseline"))
            for env_id, hp in table_.items()}


def _per_env(items: Sequence[str], envs: Sequence[str]) -> dict[str, int]:
    """``SHORT_ID=N`` (e.g. ``VsaUT2-Throw-v0=32768``) -> ``{env_id: N}``."""
    out: dict[str, int] = {}
    for it in items:
        short, _, n = it.partition("=")
        match = [e for e in envs if e.split("/")[-1] == short or e == short]
        if not match or not n:
            raise SystemExit(f"--timesteps-for and --residual-timesteps-for take ENV=N with ENV one of "
                             f"{list(envs)}, got {it!r}")
        out[match[0]] = int(n)
    return out


def budgets(envs: Sequence[str], timesteps: int, timesteps_for: Sequence[str] = (),
            residual_timesteps_for: Sequence[str] = ()) -> tuple[dict[str, int], dict[str, int]]:
    """``(pure, residual)`` training budgets per environment: ``timesteps``, then ``--timesteps-for``; the
    residual agents take the pure budget unless ``--residual-timesteps-for`` names their own."""
    pure = {e: int(timesteps) for e in envs} | _per_env(timesteps_for, envs)
    return pure, pure | _per_env(residual_timesteps_for, envs)


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m benchmarks.rl_vs_baselines", description=__doc__.split("\n\n")[0])
    ap.add_argument("--envs", nargs="+", default=list(ENVS))
    ap.add_argument("--algo", default="ppo")
    ap.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2])
    ap.add_argument("--timesteps", type=int, default=30_000, help="training timesteps per agent")
    ap.add_argument("--timesteps-for", nargs="*", default=[], metavar="ENV=N",
                    help="per-environment timesteps, e.g. VsaUT2-Throw-v0=32768 (default: --timesteps)")
    ap.add_argument("--residual-timesteps-for", nargs="*", default=[], metavar="ENV=N",
                    help="per-environment timesteps of the residual agents (default: the pure agents' budget)")
    ap.add_argument("--residual", action="store_true",
                    help="also train residual agents (agents/hyperparams/ppo_residual.yml) where an entry exists")
    ap.add_argument("--episodes", type=int, default=5, help="evaluation episodes (held-out seeds)")
    ap.add_argument("--log-folder", default="logs/rl_vs_baselines")
    ap.add_argument("--docs", default=str(REPO / "docs"))
    ap.add_argument("--num-cpus", type=int, default=2)
    ap.add_argument("--address", default=None, help="Ray cluster (default: local instance)")
    ap.add_argument("--eval-freq", type=int, default=25_000,
                    help="periodic evaluation on the validation seeds every N timesteps (0: off)")
    ap.add_argument("--eval-episodes", type=int, default=8, help="validation episodes per periodic evaluation")
    ap.add_argument("--select", choices=("final", "best"), default="final",
                    help="evaluate each agent's final model, or the best model of the periodic evaluation "
                         "(validation return under the agent's training reward, failures charged per skipped step)")
    ap.add_argument("--skyhook-gains", nargs="*", type=float, default=[], metavar="C_SKY",
                    help="also evaluate the quarter-car skyhook at these damping gains (N s/m; default gain 1000)")
    ap.add_argument("--reuse-baselines", action="store_true",
                    help="take the baselines' episodes from the previous docs/agents_results.json")
    ap.add_argument("--replot", action="store_true",
                    help="only redraw docs/img/pareto_*.png from docs/agents_results.json (no training)")
    a = ap.parse_args(argv)
    if a.replot:
        rec = read_json(Path(a.docs) / "agents_results.json", {}) or {}
        for env_id, r in rec.get("envs", {}).items():
            out = Path(a.docs) / "img" / f"pareto_{env_id.split('/')[1]}.png"
            pareto_plot(env_id, r["agents"], r["baselines"], out)
        return 0
    if len(a.seeds) < 3:
        print("note: fewer than 3 seeds give no meaningful interval", file=sys.stderr)
    from agents.sweep import make_trials, run_sweep

    docs = Path(a.docs)
    results_path = docs / "agents_results.json"
    previous = read_json(results_path, {}) or {}
    cache: dict[str, Any] = previous.get("baseline_cache", {}) if a.reuse_baselines else {}
    steps_for, res_steps_for = budgets(a.envs, a.timesteps, a.timesteps_for, a.residual_timesteps_for)
    res_envs = residual_envs() if a.residual else {}
    trials: list[dict[str, Any]] = []
    common = {"episodes": a.episodes, "save_freq": 50_000, "eval_freq": a.eval_freq,
              "eval_episodes": a.eval_episodes, "select": a.select}
    if a.select == "best" and a.eval_freq <= 0:
        raise SystemExit("--select best needs the periodic evaluation: --eval-freq > 0")
    for env_id in a.envs:  # residual trials first: they are the slow ones (baseline in the loop)
        if env_id in res_envs:
            trials += make_trials([env_id], [a.algo], a.seeds, timesteps=res_steps_for[env_id],
                                  log_folder=str(Path(a.log_folder) / "residual"),
                                  hyperparams=str(RESIDUAL_HYPERPARAMS),
                                  variant="residual", eval_kwargs=SELECTION_KWARGS.get(env_id, {}), **common)
    for env_id in a.envs:
        trials += make_trials([env_id], [a.algo], a.seeds, timesteps=steps_for[env_id], log_folder=a.log_folder,
                              variant="pure", eval_kwargs=SELECTION_KWARGS.get(env_id, {}), **common)
    for d in mark_stale(trials):
        print(f"note: {d} was trained with other hyperparameters; training again", file=sys.stderr)
    base_all: dict[str, dict[str, list[dict[str, Any]]]] = {}

    def baselines_job() -> None:  # numpy only: runs in the driver while Ray trains the agents
        for env_id in a.envs:
            gains = a.skyhook_gains if env_id == "vsa_gym/ELPAS-QuarterCar-v0" else ()
            base_all[env_id] = evaluate_baselines(env_id, a.episodes, cache, gains)

    wall0 = time.perf_counter()
    worker = threading.Thread(target=baselines_job)
    worker.start()
    swept = run_sweep(trials, a.address, a.num_cpus)
    worker.join()
    from agents.evaluate import evaluate_agent, split_reward_kwargs, training_env_kwargs

    for r in swept:  # metrics cached under another reward than today's default one: evaluate again
        m, model, env_id = r["metrics"], r["model"], r["trial"]["env_id"]
        if m is None:
            continue
        dropped = split_reward_kwargs(env_id, training_env_kwargs(model, env_id))[1]
        agent = m.get("agent", {})
        # taken before returns were scored under the default reward, or before REWARD_KWARGS listed every
        # reward-only argument the agent was trained with (the throw's shaping)
        if dropped and (agent.get("reward") != "default"
                        or set(agent.get("training_reward_kwargs", {})) != set(dropped)):
            r["metrics"] = evaluate_agent(model, env_id, a.episodes)
    wall_min = (time.perf_counter() - wall0) / 60.0
    command = "python -m benchmarks.rl_vs_baselines " + " ".join(argv if argv is not None else sys.argv[1:])
    train_cpu = sum(r["train_info"]["cpu_s"] for r in swept) / 60.0
    budget = ", ".join(f"{e.split('/')[-1]} {steps_for[e]}"
                       + (f" (residual {res_steps_for[e]})" if e in res_envs and res_steps_for[e] != steps_for[e]
                          else "") for e in a.envs)
    models = ("final models" if a.select == "final" else
              f"each agent's best_model.zip: the checkpoint with the highest mean return on {a.eval_episodes} "
              f"validation episodes (seeds 1000000 + k), evaluated every {a.eval_freq} steps (and at the end) under "
              f"the reward the agent was trained with, a failure charged for every step it skips")
    sections = [f"Made by `{command}` ({a.algo.upper()}, timesteps per agent: {budget}; seeds {a.seeds}; "
                f"{models}; {a.episodes} held-out test episodes (seeds 2000000 + k) of the full length per policy; "
                f"returns under each environment's default reward). Training CPU time of "
                f"all agents: {train_cpu:.1f} min (sum over the trials, including reused runs); wall time of the "
                f"command: {wall_min:.1f} min.\n"]
    record: dict[str, Any] = {"command": command, "algo": a.algo, "timesteps": steps_for,
                              "residual_timesteps": {e: res_steps_for[e] for e in res_envs}, "seeds": a.seeds,
                              "episodes": a.episodes, "train_cpu_min": train_cpu, "wall_min": wall_min,
                              "select": a.select, "eval_freq": a.eval_freq, "eval_episodes": a.eval_episodes,
                              "selection_kwargs": SELECTION_KWARGS,
                              "envs": {}, "baseline_cache": cache}
    for env_id in a.envs:
        agents: dict[str, list[dict[str, Any]]] = {}
        for variant in ("pure", "residual"):
            rows = [{"seed": r["train_info"]["seed"], "cpu_min": r["train_info"]["cpu_s"] / 60.0,
                     "wall_min": r["train_info"]["wall_s"] / 60.0, "model": r["model"],
                     "selected_step": r["selected_step"],
                     "reused": r["reused"], "metrics": {k: v for k, v in r["metrics"].items() if k != "agent"}}
                    for r in swept if r["trial"]["env_id"] == env_id and r["trial"]["variant"] == variant]
            if rows:
                k = (steps_for if variant == "pure" else res_steps_for)[env_id] // 1000
                hp_file = RESIDUAL_HYPERPARAMS if variant == "residual" else None
                note = (wrapper_note(a.algo, env_id, hp_file)
                        + reward_note(training_reward(a.algo, env_id, hp_file)))
                name = (f"{a.algo.upper()} ({k}k steps{note})" if variant == "pure" else
                        f"residual {a.algo.upper()} over {res_envs[env_id]} ({k}k steps{note}; not a pure agent)")
                agents[name] = rows
        base = base_all[env_id]
        short = env_id.split("/")[1]
        pareto_plot(env_id, agents, base, docs / "img" / f"pareto_{short}.png")
        chosen = "".join(f"\n\n{name}: checkpoints chosen at "
                         + ", ".join(f"{r['selected_step']} (seed {r['seed']})" for r in rows) + " steps."
                         for name, rows in agents.items()) if a.select == "best" else ""
        sections.append(f"#### {env_id}\n\n{table(env_id, agents, base)}{chosen}\n\n"
                        f"![pareto](img/pareto_{short}.png)\n")
        record["envs"][env_id] = {"agents": agents, "baselines": base}
    write_json(results_path, record)
    update_doc(docs / "agents.md", "\n".join(sections))
    print("\n".join(sections))
    return 0


if __name__ == "__main__":
    sys.exit(main())
