"""Smoke training on every environment (save, reload, deterministic evaluation) and exact resumption."""

from __future__ import annotations

import json
import os
import pickle
import signal
from pathlib import Path

import numpy as np
import pytest
from stable_baselines3.common.callbacks import BaseCallback

from agents.common import checkpoints, env_name, read_hyperparams, vecnormalize_for
from agents.evaluate import evaluate_agent, load_agent
from agents.evaluate import main as evaluate_main
from agents.hold import hold_steps
from agents.train import train
from tests.agents.conftest import EPISODE, tiny
from vsa_gym.envs import ENV_IDS

FORCE = "vsa_gym/ELPAS-ForceTracking-v0"


def _check_layout(info: dict, env_id: str, checkpoint_steps: list[int]) -> Path:
    save = Path(info["save_path"])
    name = env_name(env_id)
    assert save.parent.name == info["algo"] and save.name == f"{name}_1"
    assert (save / f"{name}.zip").exists()
    assert (save / name / "vecnormalize.pkl").exists()
    for f in ("config.yml", "args.yml", "command.txt"):
        assert (save / name / f).exists()
    got = [n for n, _ in checkpoints(save, info["algo"] != "ppo", normalized=True)]
    assert got == checkpoint_steps
    assert (save / "evaluations.npz").exists() and (save / "best_model.zip").exists()
    assert (save / "best_model_vecnormalize.pkl").exists()
    assert any((save / "tb").rglob("events.out.tfevents.*"))
    return save


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_ppo_smoke_every_env(tmp_path: Path, env_id: str) -> None:
    info = train(env_id, "ppo", 512, seed=3, log_folder=tmp_path, params=tiny("ppo"), save_freq=256,
                 eval_freq=256, eval_episodes=2, n_eval_envs=2)
    assert info["status"] == "finished" and info["num_timesteps"] == 512 and info["cpu_s"] > 0
    save = _check_layout(info, env_id, [256, 512])
    evals = np.load(save / "evaluations.npz")
    assert list(evals["timesteps"]) == [256, 512]
    # held-out evaluation episodes of the training length, counted in agent decisions (k control steps each where
    # the entry holds the actions, agents.hold)
    steps = hold_steps(read_hyperparams("ppo", env_id).get("vec_env_wrapper"))
    decisions = EPISODE if steps is None else -(-EPISODE // steps)
    assert np.all(evals["ep_lengths"] == decisions)

    model = save / f"{env_name(env_id)}.zip"
    pol = load_agent(model)
    assert pol.vecnormalize is not None and pol.vecnormalize.obs_rms.count > 512  # statistics were learnt
    obs = np.ones((3, pol.model.observation_space.shape[0]), dtype=np.float32)
    assert not np.allclose(pol.normalize(obs), obs)
    a1, a2 = pol(obs), load_agent(model)(obs)
    np.testing.assert_array_equal(a1, a2)  # reload gives the same deterministic policy
    assert a1.shape == (3, pol.model.action_space.shape[0]) and np.all(np.abs(a1) <= 1)

    r1 = evaluate_agent(model, env_id, episodes=2, episode_steps=60)
    r2 = evaluate_agent(model, env_id, episodes=2, episode_steps=60)
    assert r1 == r2
    assert r1["steps"] > 0 and np.isfinite(r1["metric_value"]) and np.isfinite(r1["energy_J"])


@pytest.mark.parametrize("algo", ["sac", "td3", "tqc"])
def test_off_policy_smoke_and_cli_evaluate(tmp_path: Path, algo: str) -> None:
    info = train(FORCE, algo, 400, seed=0, log_folder=tmp_path, params=tiny(algo), save_freq=200, eval_freq=200,
                 eval_episodes=2, n_eval_envs=2)
    save = _check_layout(info, FORCE, [200, 400])
    assert (save / "rl_model_replay_buffer_400_steps.pkl").exists()
    out = tmp_path / "m.json"
    assert evaluate_main([str(save / "rl_model_400_steps.zip"), "--env", FORCE, "--episodes", "2",
                          "--episode-steps", "50", "--json", str(out)]) == 0
    res = json.loads(out.read_text())
    for key in ("force_rms_N", "energy_J", "energy_charged_J", "peak_power_W", "violations", "metric_value"):
        assert key in res
    assert res["agent"]["algo"] == algo and res["agent"]["vecnormalize"].endswith("rl_model_vecnormalize_400_steps.pkl")
    assert res["metric_value"] == evaluate_agent(save / "rl_model_400_steps.zip", FORCE, 2,
                                                 episode_steps=50)["metric_value"]
    # --env-kwargs: other conditions (here a stress set at the top of the force range) on top of the training ones
    stress = tmp_path / "stress.json"
    assert evaluate_main([str(save / "rl_model_400_steps.zip"), "--env", FORCE, "--episodes", "2",
                          "--episode-steps", "50", "--json", str(stress),
                          "--env-kwargs", "{force_range: [3000, 3200]}"]) == 0
    res2 = json.loads(stress.read_text())
    assert res2["agent"]["env_kwargs"]["force_range"] == [3000, 3200]
    assert res2["metric_value"] != res["metric_value"]
    with pytest.raises(SystemExit):
        evaluate_main([str(save / "rl_model_400_steps.zip"), "--env", FORCE, "--env-kwargs", "[1, 2]"])


class _Crash(BaseCallback):
    """Raise once the step count reaches ``at`` (a crash in the middle of a step)."""

    def __init__(self, at: int) -> None:
        super().__init__()
        self.at = at

    def _on_step(self) -> bool:
        if self.num_timesteps >= self.at:
            raise RuntimeError("crash")
        return True


class _CtrlC(BaseCallback):
    """Send this process SIGINT (a real Ctrl-C) once the step count reaches ``at``."""

    def __init__(self, at: int) -> None:
        super().__init__()
        self.at, self.sent = at, False

    def _on_step(self) -> bool:
        if self.num_timesteps >= self.at and not self.sent:
            self.sent = True
            os.kill(os.getpid(), signal.SIGINT)
        return True


class _Start(BaseCallback):
    """Record the step count, VecNormalize statistics and replay buffer when training (re)starts."""

    def __init__(self) -> None:
        super().__init__()
        self.seen: dict = {}

    def _on_training_start(self) -> None:
        vn = self.model.get_vec_normalize_env()
        rb = self.model.replay_buffer
        self.seen = {"steps": self.model.num_timesteps, "obs_mean": vn.obs_rms.mean.copy(),
                     "count": vn.obs_rms.count, "rb_pos": rb.pos, "rb_obs": rb.observations[: rb.pos].copy()}

    def _on_step(self) -> bool:
        return True


def _buffer(path: Path):
    with open(path, "rb") as fh:
        return pickle.load(fh)


def test_resume_after_crash_and_interrupt(tmp_path: Path) -> None:
    kw = dict(log_folder=tmp_path, params=tiny("sac"), save_freq=200, eval_freq=0)
    # 1. a crash at 500 steps: only the periodic checkpoints (200, 400) exist afterwards
    with pytest.raises(RuntimeError):
        train(FORCE, "sac", 800, seed=5, callbacks=[_Crash(500)], **kw)
    save = tmp_path / "sac" / f"{env_name(FORCE)}_1"
    assert [n for n, _ in checkpoints(save, True, True)] == [200, 400]
    rb400 = _buffer(save / "rl_model_replay_buffer_400_steps.pkl")
    with open(save / "rl_model_vecnormalize_400_steps.pkl", "rb") as fh:
        vn400 = pickle.load(fh)

    # 2. resume: starts at 400 with the checkpoint's buffer and statistics; Ctrl-C at 600 checkpoints and stops
    start = _Start()
    info = train(FORCE, "sac", 800, seed=5, resume=True, callbacks=[start, _CtrlC(600)], **kw)
    assert info["status"] == "interrupted" and info["num_timesteps"] == 600
    assert start.seen["steps"] == 400
    # the checkpoint's statistics plus the n_envs = 2 reset observations of the fresh episodes
    # (a new VecNormalize would start from a count of 1e-4)
    assert start.seen["count"] == pytest.approx(vn400.obs_rms.count + 2, abs=1e-9)
    implied_reset_obs = (start.seen["obs_mean"] * start.seen["count"] - vn400.obs_rms.mean * vn400.obs_rms.count) / 2
    space = vn400.observation_space
    assert np.all(implied_reset_obs >= space.low - 1e-3) and np.all(implied_reset_obs <= space.high + 1e-3)
    assert start.seen["rb_pos"] == rb400.pos == 200  # 400 transitions in rows of n_envs = 2
    np.testing.assert_array_equal(start.seen["rb_obs"], rb400.observations[: rb400.pos])
    assert [n for n, _ in checkpoints(save, True, True)][-1] == 600

    # 3. resume again from the interrupt checkpoint and finish: nothing of the earlier data is lost
    start2 = _Start()
    info = train(FORCE, "sac", 800, seed=5, resume=True, callbacks=[start2], **kw)
    assert info["status"] == "finished" and info["num_timesteps"] == 800 and start2.seen["steps"] == 600
    rb_final = _buffer(save / "rl_model_replay_buffer_800_steps.pkl")
    assert rb_final.pos == 400
    rb600 = _buffer(save / "rl_model_replay_buffer_600_steps.pkl")
    np.testing.assert_array_equal(rb_final.observations[:300], rb600.observations[:300])
    np.testing.assert_array_equal(rb_final.observations[:200], rb400.observations[:200])
    np.testing.assert_array_equal(rb_final.rewards[:200], rb400.rewards[:200])
    assert [s["status"] for s in info["segments"]] == ["failed", "interrupted", "finished"]
    assert [(s["start"], s["end"]) for s in info["segments"]] == [(0, 500), (400, 600), (600, 800)]
    assert vecnormalize_for(save / f"{env_name(FORCE)}.zip") is not None
    # the same TensorBoard run continues (one SAC_1 folder)
    assert sorted(p.name for p in (save / "tb").iterdir()) == ["SAC_1"]


def test_resume_needs_a_run(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError):
        train(FORCE, "sac", 100, seed=9, log_folder=tmp_path, resume=True)


def test_periodic_evaluation_scores_the_default_reward_and_the_final_model(tmp_path: Path) -> None:
    """best_model.zip is chosen on validation returns under the environment's default reward (plus the
    evaluation kwargs), the final model is evaluated too, and a resumed run keeps the earlier record."""
    from agents.common import EVAL_SEED_BASE
    from agents.sweep import best_step

    params = tiny("ppo", env_kwargs={"max_episode_steps": EPISODE, "w_energy": 50.0})
    kw = dict(log_folder=tmp_path, params=params, save_freq=256, eval_freq=300, eval_episodes=2,
              eval_reward="default", eval_kwargs={"failure_rate": 2.0})
    info = train(FORCE, "ppo", 512, seed=1, **kw)
    save = Path(info["save_path"])
    ev = np.load(save / "evaluations.npz")
    assert list(ev["timesteps"]) == [300, 512]  # periodic at 300, then the final model at 512
    # the final evaluation is the final model's return on the validation seeds, under the default reward
    model = save / f"{env_name(FORCE)}.zip"
    scored = evaluate_agent(model, FORCE, 2, EVAL_SEED_BASE, episode_steps=EPISODE,
                            env_kwargs={"failure_rate": 2.0})
    assert ev["results"][-1].mean() == pytest.approx(scored["return"], rel=1e-5)
    trained_for = evaluate_agent(model, FORCE, 2, EVAL_SEED_BASE, episode_steps=EPISODE, reward="training")
    assert abs(trained_for["return"] - scored["return"]) > 1.0  # w_energy = 50 would have scored differently
    assert best_step(save) == int(ev["timesteps"][np.argmax(ev["results"].mean(axis=1))])

    info = train(FORCE, "ppo", 1024, seed=1, resume=True, **kw)
    ev2 = np.load(save / "evaluations.npz")
    assert list(ev2["timesteps"][:2]) == [300, 512] and ev2["timesteps"][-1] == 1024
    np.testing.assert_array_equal(ev2["results"][:2], ev["results"])
