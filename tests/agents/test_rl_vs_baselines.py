"""The comparison's statistics, table and doc update (the training itself is covered by the sweep test)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from benchmarks.rl_vs_baselines import MARK_BEGIN, MARK_END, interval, table, update_doc


def test_interval_is_the_student_t_interval() -> None:
    m, lo, hi = interval([1.0, 2.0, 3.0])
    assert m == 2.0
    assert hi - m == pytest.approx(4.302652729911275 * 1.0 / 3**0.5)  # t_{0.975, 2} s / sqrt(n)
    assert interval([5.0]) == (5.0, 5.0, 5.0)


def test_table_rows_and_doc_section(tmp_path: Path) -> None:
    env = "vsa_gym/ELPAS-ForceTracking-v0"
    metrics = {"force_rms_N": 100.0, "energy_J": 2.0, "peak_power_W": 50.0, "violations": 0, "steps": 50.0,
               "return": -10.0}
    agents = {"PPO": [{"cpu_min": 1.0 + s, "metrics": {**metrics, "force_rms_N": 100.0 + s}} for s in range(3)]}
    base = {"cascade": [dict(metrics, force_rms_N=50.0, episodes=2)]}
    t = table(env, agents, base)
    lines = t.splitlines()
    assert len(lines) == 4 and lines[2].startswith("| cascade | 2 ep. (mean) | 50.0 |")
    assert "| **PPO** | 3 seeds | 101.0 [98.5, 103.5] |" in lines[3] and lines[3].endswith("| 2.0 [-0.5, 4.5] |")
    doc = tmp_path / "agents.md"
    doc.write_text(f"intro\n{MARK_BEGIN}\nold\n{MARK_END}\noutro\n")
    update_doc(doc, "new table")
    assert doc.read_text() == f"intro\n{MARK_BEGIN}\nnew table\n{MARK_END}\noutro\n"


QC = "vsa_gym/ELPAS-QuarterCar-v0"


def _fake_run(log: Path, algo: str, env_id: str, seed: int, steps: int, config: dict) -> Path:
    import yaml

    from agents.common import env_name
    from agents.common import write_json as wj

    save = log / algo / f"{env_name(env_id)}_1"
    (save / env_name(env_id)).mkdir(parents=True)
    (save / env_name(env_id) / "config.yml").write_text(yaml.dump(dict(sorted(config.items()))))
    model = save / f"{env_name(env_id)}.zip"
    model.write_bytes(b"")
    wj(save / "train_info.json", {"status": "finished", "seed": seed, "num_timesteps": steps, "model": str(model),
                                  "save_path": str(save)})
    return save


def test_runs_with_other_hyperparameters_are_trained_again(tmp_path: Path) -> None:
    from agents.common import read_hyperparams
    from benchmarks.rl_vs_baselines import mark_stale

    hp = read_hyperparams("ppo", QC)
    trial = {"env_id": QC, "algo": "ppo", "seed": 0, "timesteps": 1000, "log_folder": str(tmp_path / "same")}
    _fake_run(tmp_path / "same", "ppo", QC, 0, 1000, hp)
    assert mark_stale([trial]) == [] and "retrain" not in trial  # same settings: reused
    other = dict(trial, log_folder=str(tmp_path / "other"))
    save = _fake_run(tmp_path / "other", "ppo", QC, 0, 1000, dict(hp, learning_rate="lin_1e-5"))
    assert mark_stale([other]) == [str(save)] and other["retrain"] is True
    fewer = dict(trial, timesteps=999)  # no finished run with that budget: nothing to mark
    assert mark_stale([fewer]) == [] and "retrain" not in fewer


def test_training_reward_is_named_in_the_row(tmp_path: Path) -> None:
    import yaml

    from benchmarks.rl_vs_baselines import reward_note, training_reward

    f = tmp_path / "hp.yml"
    f.write_text(yaml.dump({QC: {"n_timesteps": 10, "policy": "MlpPolicy",
                                 "env_kwargs": {"control_mode": "current", "w_energy": 0.01}}}))
    kw = training_reward("ppo", QC, f)
    assert kw == {"w_energy": 0.01} and reward_note(kw) == "; trained with w_energy = 0.01"
    assert reward_note({}) == ""


def test_skyhook_gain_rows_trade_comfort_for_energy() -> None:
    from baselines.metrics import evaluate_policy
    from benchmarks.rl_vs_baselines import baseline_factories

    rows = baseline_factories(QC, [3000.0, 250.0, 1000.0])
    assert list(rows)[-2:] == ["skyhook cascade, c_sky = 250 N s/m", "skyhook cascade, c_sky = 3000 N s/m"]
    res = {name: evaluate_policy(QC, fac, [2_000_000], episode_steps=1500, env_kwargs=kw)
           for name, (fac, kw) in rows.items() if name.startswith("skyhook")}
    e = [res[n]["energy_J"] for n in ("skyhook cascade, c_sky = 250 N s/m", "skyhook cascade",
                                       "skyhook cascade, c_sky = 3000 N s/m")]
    assert e[0] < e[1] < e[2]  # more skyhook damping draws more electrical energy
    with pytest.raises(ValueError, match=">= 0"):
        baseline_factories(QC, [-1.0])


def test_a_run_is_found_by_its_budget_not_its_rounded_step_count(tmp_path: Path) -> None:
    """PPO ends on a whole rollout (1 500 000 -> 1 507 328 steps with 64 x 128): the run of budget N is reused."""
    from agents.common import write_json as wj
    from agents.sweep import finished_run

    save = _fake_run(tmp_path, "ppo", QC, 0, 1024, {})
    info = json.loads((save / "train_info.json").read_text())
    wj(save / "train_info.json", {**info, "target_timesteps": 1000})
    assert finished_run(tmp_path, QC, "ppo", 0, 1000)["save_path"] == str(save)
    assert finished_run(tmp_path, QC, "ppo", 0, 1024) is None


def test_residual_agents_can_have_their_own_budget() -> None:
    from benchmarks.rl_vs_baselines import budgets

    envs = [QC, "vsa_gym/VsaUT2-PositionStiffness-v0"]
    pure, res = budgets(envs, 1000, ["VsaUT2-PositionStiffness-v0=6000"], ["VsaUT2-PositionStiffness-v0=500"])
    assert pure == {QC: 1000, envs[1]: 6000} and res == {QC: 1000, envs[1]: 500}
    assert budgets(envs, 1000, ["ELPAS-QuarterCar-v0=20"])[1] == {QC: 20, envs[1]: 1000}  # default: the pure one
    with pytest.raises(SystemExit, match="residual-timesteps-for"):
        budgets(envs, 1000, [], ["Unknown-v0=5"])


def test_row_labels_name_a_warm_start_and_a_planned_noise(tmp_path: Path) -> None:
    from benchmarks.rl_vs_baselines import wrapper_note

    f = tmp_path / "ppo.yml"
    f.write_text("""vsa_gym/VsaUT2-PositionStiffness-v0:
  n_timesteps: 1000
  policy: MlpPolicy
  vec_env_wrapper: [{agents.features.LeakyIntegralVecEnv: {channels: [r_ref]}}]
  frame_stack: 4
  callback:
    - agents.warm_start.BehaviourCloningWarmStart: {baseline: decoupled}
    - agents.exploration.LogStdSchedule: {start: -1.5, end: -3.5}
""")
    note = wrapper_note("ppo", "vsa_gym/VsaUT2-PositionStiffness-v0", f)
    assert note == ("; observes the leaky integral of r_ref; sees the last 4 observations"
                    "; warm-started by cloning decoupled"
                    "; exploration noise planned (log std -1.5 to -3.5)")
