"""Behaviour-cloning warm start: the clone imitates the baseline far better than the initial policy, on
observations the clone itself visits; a resumed run is not cloned again; the critic warm-up leaves the actor
alone; the ``callback`` hyperparameter builds it as rl-zoo3 does."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from stable_baselines3 import PPO

from agents.common import make_callbacks, make_train_env, process_hyperparams
from agents.residual import baseline_factory, reset_rows, task_env
from agents.warm_start import BehaviourCloningWarmStart

PS = "vsa_gym/VsaUT2-PositionStiffness-v0"
NORMALIZE = {"norm_obs": True, "norm_reward": True, "gamma": 0.98}


def _model(seed: int = 0) -> PPO:
    env = make_train_env(PS, 4, seed, {"failure_rate": 5.0}, NORMALIZE)
    return PPO("MlpPolicy", env, n_steps=64, batch_size=128, n_epochs=2, gamma=0.98, seed=seed,
               policy_kwargs={"log_std_init": -2.5, "net_arch": {"pi": [64, 64], "vf": [64, 64]}})


def _imitation_error(model: PPO, seed: int, steps: int = 300) -> float:
    """RMS gap between the policy's mean action and the decoupled controller's, on states the policy visits
    (fresh episodes of an environment the warm start never saw)."""
    env = make_train_env(PS, 4, seed, None, None)
    vn = model.get_vec_normalize_env()
    factory = baseline_factory("decoupled")
    ctrl = factory(task_env(env))
    obs = env.reset()
    gaps = []
    for _ in range(steps):
        label = ctrl(obs)
        with torch.no_grad():
            o = torch.as_tensor(vn.normalize_obs(obs))
            act = model.policy.get_distribution(o).distribution.mean.numpy()
        gaps.append((np.clip(act, -1, 1) - label) ** 2)
        obs, _, done, _ = env.step(np.clip(act, -1, 1))
        rows = np.flatnonzero(done)
        if rows.size:
            fresh = factory(task_env(env))
            fresh(obs[rows])
            reset_rows(ctrl, fresh, rows, 4)
    return float(np.sqrt(np.mean(gaps)))


def test_the_clone_imitates_the_controller_on_its_own_states(tmp_path) -> None:  # noqa: ANN001
    model = _model()
    before = _imitation_error(model, 77)
    cb = BehaviourCloningWarmStart("decoupled", steps=1000, dagger_rounds=1, epochs=40, batch_size=128,
                                   critic_warmup=10_000, record_path=str(tmp_path / "ws.json"))
    model.learn(64 * 4, callback=cb)
    after = _imitation_error(model, 77)
    assert after < 0.5 * before, (before, after)
    rounds = cb.record["rounds"]
    assert [r["actor"] for r in rounds] == ["baseline", "clone"]
    assert rounds[1]["samples"] == 2 * 1000 * 4 and np.isfinite(cb.record["value_mse"])
    assert (tmp_path / "ws.json").exists()


def test_a_resumed_run_is_not_cloned_again_and_the_warmup_freezes_the_actor() -> None:
    model = _model(1)
    cb = BehaviourCloningWarmStart("decoupled", steps=100, dagger_rounds=0, epochs=2, critic_warmup=10_000)
    model.learn(64 * 4, callback=cb)
    actor = {k: v.clone() for k, v in model.policy.state_dict().items() if "policy_net" in k or "action_net" in k}
    critic = {k: v.clone() for k, v in model.policy.state_dict().items() if "value_net" in k}
    model.learn(64 * 4 * 2, callback=cb, reset_num_timesteps=False)  # still inside the warm-up: no clone, no actor
    state = model.policy.state_dict()
    assert all(torch.equal(state[k], v) for k, v in actor.items())
    assert any(not torch.equal(state[k], v) for k, v in critic.items())
    assert len(cb.record["rounds"]) == 1  # the second learn() did not clone again


def test_the_callback_hyperparameter_builds_it_as_rl_zoo3_does() -> None:
    from rl_zoo3.utils import get_callback_list

    spec = [{"agents.warm_start.BehaviourCloningWarmStart": {"baseline": "decoupled", "steps": 10}}]
    ours = make_callbacks(process_hyperparams({"n_timesteps": 10, "callback": spec}, 2)["callback"])
    zoo = get_callback_list({"callback": spec})
    assert [type(c) for c in ours] == [type(c) for c in zoo] == [BehaviourCloningWarmStart]
    assert ours[0].steps == zoo[0].steps == 10
    with pytest.raises(ValueError, match="callback: cannot import 'agents.nope.Missing'"):
        make_callbacks("agents.nope.Missing")
    with pytest.raises(ValueError, match="dagger_rounds"):
        BehaviourCloningWarmStart(dagger_rounds=-1)


def test_a_wrapper_that_changes_the_action_is_refused() -> None:
    env = make_train_env(PS, 2, 0, None, NORMALIZE,
                         vec_env_wrapper=[{"agents.hold.ActionHoldVecEnv": {"steps": 2}}])
    model = PPO("MlpPolicy", env, n_steps=16, batch_size=32, seed=0)
    with pytest.raises(ValueError, match="cannot clone a baseline through ActionHoldVecEnv"):
        model.learn(32, callback=BehaviourCloningWarmStart("decoupled", steps=10))
