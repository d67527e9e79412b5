"""Our hyperparameter files are rl-zoo3 files: rl-zoo3's own loader reads them, and ours agrees with it."""

from __future__ import annotations

import argparse
from pathlib import Path

import gymnasium as gym
import pytest
import rl_zoo3.exp_manager as rl_zoo3_exp  # noqa: E402  (installed by the test extra)
import yaml

from agents.common import ALGO_NAMES, HYPERPARAMS_DIR, LinearSchedule, process_hyperparams, read_hyperparams
from vsa_gym.envs import ENV_IDS


def _zoo(algo: str, env_id: str, tmp_path: Path):
    args = argparse.Namespace(algo=algo, env=env_id)
    return rl_zoo3_exp.ExperimentManager(args, algo, env_id, str(tmp_path), config=str(HYPERPARAMS_DIR / f"{algo}.yml"))


def test_every_algo_file_covers_every_env() -> None:
    for algo in ALGO_NAMES:
        table = yaml.safe_load((HYPERPARAMS_DIR / f"{algo}.yml").read_text())
        assert set(table) == set(ENV_IDS), algo
        for env_id, hp in table.items():
            assert {"n_timesteps", "policy", "n_envs", "normalize"} <= set(hp), (algo, env_id)


@pytest.mark.parametrize("algo", ALGO_NAMES)
@pytest.mark.parametrize("env_id", ENV_IDS)
def test_rl_zoo3_reads_our_yaml(tmp_path: Path, algo: str, env_id: str) -> None:
    zoo = _zoo(algo, env_id, tmp_path)
    raw, _ = zoo.read_hyperparameters()
    zoo_hp, env_wrapper, callbacks, vec_wrapper = zoo._preprocess_hyperparams(dict(raw))
    assert env_wrapper is None and callbacks == []
    if raw.get("vec_env_wrapper") is None:
        assert vec_wrapper is None
    else:  # rl-zoo3 builds our observation-feature or action-hold wrapper on its own DummyVecEnv
        from stable_baselines3.common.vec_env import DummyVecEnv

        from agents.features import LeakyIntegralVecEnv
        from agents.hold import ActionHoldVecEnv

        base = gym.make(env_id, **zoo.env_kwargs)
        wrapped = vec_wrapper(DummyVecEnv([lambda: gym.make(env_id, **zoo.env_kwargs)]))
        assert isinstance(wrapped, (LeakyIntegralVecEnv, ActionHoldVecEnv))
        extra = len(wrapped.channels) if isinstance(wrapped, LeakyIntegralVecEnv) else 0
        assert wrapped.observation_space.shape[0] == base.observation_space.shape[0] + extra
    assert zoo.normalize is True  # rl-zoo3 wraps in VecNormalize, as we do

    ours = process_hyperparams(read_hyperparams(algo, env_id), n_actions=2)
    assert ours["n_envs"] == zoo.n_envs and ours["n_timesteps"] == zoo.n_timesteps
    assert ours["normalize"] == zoo.normalize_kwargs
    assert ours["model"]["policy_kwargs"] == zoo_hp["policy_kwargs"]
    for key, value in zoo_hp.items():
        if key in ("learning_rate", "clip_range", "clip_range_vf"):
            assert callable(ours["model"][key]) or isinstance(ours["model"][key], float)
            for p in (1.0, 0.5):
                zv = value(p) if callable(value) else value
                ov = ours["model"][key](p) if callable(ours["model"][key]) else ours["model"][key]
                assert ov == pytest.approx(zv)
        elif key not in ("noise_type", "noise_std"):
            assert ours["model"][key] == value, key


def test_schedules_and_bad_keys() -> None:
    hp = process_hyperparams({"n_timesteps": 10, "learning_rate": "lin_3e-4", "normalize": False}, 1)
    assert isinstance(hp["model"]["learning_rate"], LinearSchedule)
    assert hp["model"]["learning_rate"](0.5) == pytest.approx(1.5e-4) and hp["normalize"] is None
    with pytest.raises(ValueError, match="not supported"):
        process_hyperparams({"n_timesteps": 10, "env_wrapper": "x"}, 1)
    with pytest.raises(ValueError, match="not found"):
        read_hyperparams("ppo", "vsa_gym/Nope-v0")
