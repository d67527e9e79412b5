"""``benchmarks.agents_dev``: agents and baselines on the development seeds, with groups and a stress set."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from agents.common import DEV_SEED_BASE, EVAL_SEED_BASE, METRIC_SEED_BASE
from agents.evaluate import evaluate_agent
from agents.train import train
from benchmarks.agents_dev import main
from tests.agents.conftest import tiny

FORCE = "vsa_gym/ELPAS-ForceTracking-v0"


def test_dev_set_rows_groups_and_stress_arguments(tmp_path: Path) -> None:
    assert len({EVAL_SEED_BASE, METRIC_SEED_BASE, DEV_SEED_BASE}) == 3
    info = train(FORCE, "ppo", 256, seed=1, log_folder=tmp_path, params=tiny("ppo"), save_freq=0, eval_freq=0)
    model = info["model"]
    out = tmp_path / "dev.json"
    assert main(["--env", FORCE, "--episodes", "2", "--episode-steps", "30", "--models", model, "--models", model,
                 "--env-kwargs", "{force_range: [3000, 3200]}", "--json", str(out)]) == 0
    rec = json.loads(out.read_text())
    assert rec["seed_base"] == DEV_SEED_BASE and rec["env_kwargs"] == {"force_range": [3000, 3200]}
    names = [r["policy"] for r in rec["rows"]]
    assert names == ["group 1 (1 models: mean)", model, "group 2 (1 models: mean)", model, "zero action",
                     "cascade (paper)"]
    assert [r["kind"] for r in rec["rows"]] == ["group", "model", "group", "model", "baseline", "baseline"]
    assert all(len(r["ended_after"]) == len(r["ended"]) for r in rec["rows"] if r["kind"] != "group")
    direct = evaluate_agent(model, FORCE, 2, DEV_SEED_BASE, episode_steps=30,
                            env_kwargs={"force_range": [3000, 3200]})
    assert rec["rows"][1]["return"] == pytest.approx(direct["return"], rel=1e-12)
    assert rec["rows"][0]["return"] == rec["rows"][1]["return"] == rec["rows"][3]["return"]
    plain = evaluate_agent(model, FORCE, 2, DEV_SEED_BASE, episode_steps=30)
    assert plain["return"] != direct["return"]  # the stress arguments reached the environment
    with pytest.raises(SystemExit):
        main(["--env", FORCE, "--models", str(tmp_path / "missing.zip")])
    with pytest.raises(SystemExit):
        main(["--env", FORCE, "--env-kwargs", "[1, 2]"])


def test_stochastic_rows_sample_the_training_noise_reproducibly(tmp_path: Path) -> None:
    info = train(FORCE, "ppo", 256, seed=2, log_folder=tmp_path, params=tiny("ppo"), save_freq=0, eval_freq=0)
    model = info["model"]
    det = evaluate_agent(model, FORCE, 2, DEV_SEED_BASE, episode_steps=30)
    sto = [evaluate_agent(model, FORCE, 2, DEV_SEED_BASE, episode_steps=30, deterministic=False) for _ in range(2)]
    assert sto[0]["return"] == sto[1]["return"] != det["return"]  # seeded noise, and it reached the actions
    assert sto[0]["agent"]["deterministic"] is False and det["agent"]["deterministic"] is True
    out = tmp_path / "dev.json"
    assert main(["--env", FORCE, "--episodes", "2", "--episode-steps", "30", "--models", model, "--no-baselines",
                 "--stochastic", "--json", str(out)]) == 0
    rec = json.loads(out.read_text())
    assert rec["stochastic"] is True and rec["rows"][1]["return"] == pytest.approx(sto[0]["return"], rel=1e-12)
