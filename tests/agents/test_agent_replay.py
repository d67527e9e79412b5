"""``benchmarks.agent_replay``: one episode of an agent or a baseline, listed step by step."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from agents.evaluate import agent_policy, evaluate_agent
from agents.train import train
from benchmarks.agent_replay import main, replay
from tests.agents.conftest import tiny

FORCE = "vsa_gym/ELPAS-ForceTracking-v0"


def test_replay_matches_the_evaluation_and_lists_the_end(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    info = train(FORCE, "ppo", 256, seed=3, log_folder=tmp_path, params=tiny("ppo"), save_freq=0, eval_freq=0)
    model = info["model"]
    factory, kw, _ = agent_policy(model, FORCE)
    res = replay(FORCE, 2_000_000, factory, {**kw, "max_episode_steps": 40})
    assert res["rows"].shape == (40, len(res["columns"]) - 1) and res["truncated"]
    assert res["columns"][-2:] == ["margin_gamma_stop", "margin_i2t"]
    assert np.all(np.abs(res["rows"][:, res["columns"].index("a0") - 1]) <= 1.0)
    again = replay(FORCE, 2_000_000, agent_policy(model, FORCE)[0], {**kw, "max_episode_steps": 40})
    np.testing.assert_array_equal(res["rows"], again["rows"])  # deterministic policy, seeded episode
    # the same episode as agents.evaluate: the energy it reports is the replay's last energy_el_total
    ev = evaluate_agent(model, FORCE, 1, 2_000_000, episode_steps=40)
    assert ev["energy_J"] == pytest.approx(res["last_info"]["energy_el_total"], rel=1e-9)
    assert main(["--env", FORCE, "--seed", "2000000", "--baseline", "cascade (paper)", "--every", "10",
                 "--env-kwargs", "{max_episode_steps: 30}"]) == 0
    out = capsys.readouterr().out
    assert "episode ended after 30 steps: truncated (time limit)" in out and "margin_gamma_stop" in out
    assert len([ln for ln in out.splitlines() if ln.strip()[:1].isdigit()]) == 4  # steps 1, 11, 21 and the last
    with pytest.raises(SystemExit):
        main(["--env", FORCE, "--seed", "1", "--baseline", "no such controller"])
    from baselines.metrics import evaluate_policy

    with pytest.raises(ValueError, match="return_traces"):
        evaluate_policy(FORCE, factory, [1], episode_steps=5, return_traces="everything")
