"""Warm start by behaviour cloning: an on-policy agent begins as an imitation of a baseline controller.

::

    python -m agents.train --env vsa_gym/VsaUT2-PositionStiffness-v0 --algo ppo --timesteps 2000000 \\
        --params "callback:[{agents.warm_start.BehaviourCloningWarmStart: {baseline: decoupled}}]"

:class:`BehaviourCloningWarmStart` is an SB3 callback (so rl-zoo3 can name it too: ``callback`` in the
hyperparameters).  When training starts from step 0 (not on a resume) it

1. runs the baseline (:func:`agents.residual.baseline_factory`) on the training rows for ``steps`` control steps
   and records its observations and actions (round 0);
2. fits the policy's action mean to the recorded actions (mean squared error, Adam);
3. repeats ``dagger_rounds`` times with the *cloned policy* acting and the baseline, running beside it on the
   same observations, labelling every visited state (DAgger: Ross, Gordon & Bagnell 2011), refitting on all the
   data gathered so far, so that the clone learns what to do in the states its own errors lead to;
4. updates the ``VecNormalize`` statistics with the baseline's recorded observations and returns (round 0;
   every fit uses observations normalised by them) and fits the value function to the discounted, normalised
   returns of the last round's rollouts (the cloned policy's own value, so that the first PPO updates start
   from a critic that knows it);
5. with ``freeze_obs_normalization`` (default) keeps the observation statistics fixed from then on: the
   normalisation is part of the cloned policy, and the statistics of the noisier states that exploration
   visits would otherwise shift every input of the network (the currents most: a small voltage noise moves
   them by amperes) and change what the clone does without any update (docs/agents.md, "Position/stiffness:
   a warm start by behaviour cloning");
6. with ``critic_warmup`` > 0 freezes the actor for that many training timesteps, so that PPO's first updates
   fit only the critic.

These steps are not counted as training timesteps and the training environment is reset afterwards; the
record (losses, reward per step of each round, samples) goes to ``warm_start.json`` in the run folder.

The agent that results is a learned policy with no baseline inside: at run time only the network acts.  Its
starting point, however, is the baseline's behaviour, so the comparison table labels such a row "warm-started by
cloning <baseline>" (``benchmarks.rl_vs_baselines.wrapper_note``) rather than letting it pass for an agent
learned from scratch.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.vec_env import VecEnv, VecEnvWrapper, VecNormalize

from agents.common import is_recurrent
from agents.residual import baseline_factory, check_mode, restart_rows, task_env


def _raw_env(env: VecEnv) -> tuple[VecEnv, VecNormalize | None]:
    """The layer the policy's (unnormalised) observations come from, below ``VecMonitor`` and ``VecNormalize``
    (stepping it leaves the training curve and the statistics alone), and the ``VecNormalize`` above it."""
    from stable_baselines3.common.vec_env import VecFrameStack, VecMonitor

    from agents.features import LeakyIntegralVecEnv

    vn = None
    while isinstance(env, VecEnvWrapper):
        if isinstance(env, VecFrameStack):  # the clone would be fitted on single observations
            raise ValueError("BehaviourCloningWarmStart: cannot clone into a policy of stacked frames "
                             "(frame_stack); train without frame_stack or without the warm start")
        if isinstance(env, VecNormalize):
            vn = env
        elif isinstance(env, VecMonitor):
            env = env.venv
            break
        env = env.venv
    # the baseline acts once per control step on the environment's own channels: observation features (appended
    # channels) are fine, wrappers that change what an action is (residual, action hold) are not
    inner = env
    while isinstance(inner, VecEnvWrapper):
        if not isinstance(inner, LeakyIntegralVecEnv):
            raise ValueError(f"BehaviourCloningWarmStart: cannot clone a baseline through {type(inner).__name__} "
                             "(only observation-feature wrappers may sit between the environment and the agent)")
        inner = inner.venv
    return env, vn


class BehaviourCloningWarmStart(BaseCallback):
    """Behaviour cloning (with DAgger rounds) of ``baseline`` before the first update (module docstring).

    ``steps``: control steps per row and round; ``epochs``, ``batch_size``, ``learning_rate``: the fit of the
    action mean (and, with ``value``, of the value function); ``record_path``: where to write the record
    (:func:`agents.train.train` sets ``RUN/warm_start.json``); ``critic_warmup``: for this many training
    timesteps the actor (and its noise) stays frozen and PPO's updates fit only the critic.
    """

    def __init__(self, baseline: str = "decoupled", steps: int = 5000, dagger_rounds: int = 2, epochs: int = 10,
                 batch_size: int = 1024, learning_rate: float = 1e-3, value: bool = True, critic_warmup: int = 0,
                 freeze_obs_normalization: bool = True, record_path: str | None = None, verbose: int = 0) -> None:
        super().__init__(verbose)
        if int(steps) < 1 or int(dagger_rounds) < 0 or int(epochs) < 1 or int(batch_size) < 1:
            raise ValueError(f"steps >= 1, dagger_rounds >= 0, epochs >= 1 and batch_size >= 1 required, got "
                             f"steps={steps}, dagger_rounds={dagger_rounds}, epochs={epochs}, "
                             f"batch_size={batch_size}")
        if not float(learning_rate) > 0.0:
            raise ValueError(f"learning_rate must be > 0, got {learning_rate}")
        self.baseline, self.steps, self.dagger_rounds = baseline, int(steps), int(dagger_rounds)
        self.epochs, self.batch_size, self.lr = int(epochs), int(batch_size), float(learning_rate)
        self.value, self.record_path = bool(value), record_path
        self.critic_warmup = int(critic_warmup)
        self.freeze_obs_normalization = bool(freeze_obs_normalization)
        self._frozen: list[Any] = []
        self._obs_stats: tuple[np.ndarray, np.ndarray, float] | None = None
        self.record: dict[str, Any] = {}

    # ------------------------------------------------------------------ rollouts
    def _rollout(self, raw: VecEnv, policy_acts: bool, vn: VecNormalize | None) -> dict[str, np.ndarray]:
        """``steps`` steps on every row; the baseline labels every observation, it or the clone acts."""
        factory = baseline_factory(self.baseline)
        env = task_env(raw)
        check_mode(self.baseline, env.unwrapped.task)
        n_task = len(env.unwrapped.task.obs_channels)
        ctrl = factory(env)
        if hasattr(ctrl, "reset"):
            ctrl.reset()
        obs = raw.reset()
        n = raw.num_envs
        label = np.asarray(ctrl(obs[:, :n_task]), dtype=np.float32).reshape(n, -1)
        O, A, R, D = [], [], [], []
        for _ in range(self.steps):
            act = self._predict(obs, vn) if policy_acts else label
            O.append(obs.copy())
            A.append(label)
            obs, rew, done, _ = raw.step(np.clip(act, -1.0, 1.0))
            R.append(np.asarray(rew, dtype=np.float64))
            D.append(np.asarray(done, dtype=bool))
            # the baseline advances once per step on every row; rows that start a new episode get a fresh one
            label = np.asarray(ctrl(obs[:, :n_task]), dtype=np.float32).reshape(n, -1)
            rows = np.flatnonzero(done)
            if rows.size:
                label[rows] = restart_rows(ctrl, factory, env, obs[rows, :n_task], rows, n)
        return {"obs": np.stack(O), "act": np.stack(A), "rew": np.stack(R), "done": np.stack(D)}

    def _normalise(self, obs: np.ndarray, vn: VecNormalize | None) -> np.ndarray:
        return np.asarray(obs if vn is None else vn.normalize_obs(obs), dtype=np.float32)

    def _predict(self, obs: np.ndarray, vn: VecNormalize | None) -> np.ndarray:
        import torch

        with torch.no_grad():
            o = torch.as_tensor(self._normalise(obs, vn), device=self.model.device)
            return self.model.policy.get_distribution(o).distribution.mean.cpu().numpy()

    # ------------------------------------------------------------------ fits
    def _fit(self, x: np.ndarray, y: np.ndarray, head: str) -> float:
        """Minimise the MSE of the action mean (``head="pi"``) or the value (``"vf"``) over ``epochs``."""
        import torch

        policy = self.model.policy
        opt = torch.optim.Adam(self._parameters(head), lr=self.lr)
        xt = torch.as_tensor(x, device=self.model.device)
        yt = torch.as_tensor(y, dtype=torch.float32, device=self.model.device)
        rng = np.random.default_rng(int(self.model.seed or 0))
        loss_v = float("nan")
        for _ in range(self.epochs):
            perm = rng.permutation(len(x))
            total = 0.0
            for k in range(0, len(x), self.batch_size):
                idx = torch.as_tensor(perm[k:k + self.batch_size], device=self.model.device)
                if head == "pi":
                    out = policy.get_distribution(xt[idx]).distribution.mean
                else:
                    out = policy.predict_values(xt[idx]).squeeze(-1)
                loss = torch.mean((out - yt[idx]) ** 2)
                opt.zero_grad()
                loss.backward()
                opt.step()
                total += float(loss.detach()) * len(idx)
            loss_v = total / len(x)
        return loss_v

    def _returns(self, rew: np.ndarray, done: np.ndarray, vn: VecNormalize | None) -> tuple[np.ndarray, np.ndarray]:
        """Discounted normalised returns (steps x rows) and a mask of the entries whose horizon is complete
        (an episode end or at least 5 / (1 - gamma) steps before the end of the record)."""
        gamma = float(self.model.gamma)
        r = rew if vn is None else vn.normalize_reward(rew)
        T = r.shape[0]
        G = np.zeros_like(r)
        g = np.zeros(r.shape[1])
        known = np.zeros(r.shape[1], dtype=bool)
        mask = np.zeros_like(r, dtype=bool)
        tail = int(5.0 / max(1.0 - gamma, 1e-6))
        for t in range(T - 1, -1, -1):
            g = np.where(done[t], 0.0, gamma * g) + r[t]
            known |= done[t]
            G[t] = g
            mask[t] = known | (T - t >= tail)
        return G, mask

    def _update_statistics(self, vn: VecNormalize, obs: np.ndarray, rew: np.ndarray, done: np.ndarray) -> None:
        """``VecNormalize``'s own running updates, fed with the recorded steps."""
        if vn.norm_obs:
            vn.obs_rms.update(obs.reshape(-1, obs.shape[-1]))
        if vn.norm_reward:
            ret = np.zeros(rew.shape[1])
            rets = np.empty_like(rew)
            for t in range(rew.shape[0]):
                ret = ret * vn.gamma + rew[t]
                rets[t] = ret
                ret[done[t]] = 0.0
            vn.ret_rms.update(rets.reshape(-1))

    # ------------------------------------------------------------------ callback
    def _on_training_start(self) -> None:
        from stable_baselines3.common.policies import ActorCriticPolicy

        vn_now = self.model.get_vec_normalize_env()
        if self.model.num_timesteps > 0:  # a resumed run keeps what it learned, and its frozen statistics
            if vn_now is not None and vn_now.norm_obs and self.freeze_obs_normalization:
                rms = vn_now.obs_rms
                self._obs_stats = (rms.mean.copy(), rms.var.copy(), float(rms.count))
            return
        if not isinstance(self.model.policy, ActorCriticPolicy) or is_recurrent(self.model.policy):
            raise TypeError(f"BehaviourCloningWarmStart needs an on-policy feed-forward actor-critic (PPO, A2C); got "
                            f"{type(self.model.policy).__name__}")
        raw, vn = _raw_env(self.training_env)
        data: list[dict[str, np.ndarray]] = []
        rounds = []
        for k in range(self.dagger_rounds + 1):
            d = self._rollout(raw, policy_acts=k > 0, vn=vn)
            data.append(d)
            obs = np.concatenate([x["obs"].reshape(-1, x["obs"].shape[-1]) for x in data])
            act = np.concatenate([x["act"].reshape(-1, x["act"].shape[-1]) for x in data])
            if k == 0 and vn is not None:
                self._update_statistics(vn, d["obs"], d["rew"], d["done"])
            loss = self._fit(self._normalise(obs, vn), act, "pi")
            ends = int(d["done"].sum())
            rounds.append({"round": k, "actor": "baseline" if k == 0 else "clone", "samples": int(len(obs)),
                           "action_mse": loss, "mean_reward_per_step": float(d["rew"].mean()),
                           "episode_ends": ends})
            if self.verbose:
                print(f"warm start round {k} ({rounds[-1]['actor']} acting): {len(obs)} samples, action MSE "
                      f"{loss:.4g}, reward per step {rounds[-1]['mean_reward_per_step']:.4g}, {ends} episode ends")
        self.record = {"baseline": self.baseline, "rounds": rounds}
        if self.value:
            last = data[-1] if self.dagger_rounds > 0 else self._rollout(raw, policy_acts=True, vn=vn)
            G, mask = self._returns(last["rew"], last["done"], vn)
            self.record["value_samples"] = int(mask.sum())
            if mask.any():  # (a record shorter than the discount's horizon, with no episode end, has none)
                self.record["value_mse"] = self._fit(self._normalise(last["obs"][mask], vn), G[mask], "vf")
        if vn is not None and vn.norm_obs and self.freeze_obs_normalization:
            self._obs_stats = (vn.obs_rms.mean.copy(), vn.obs_rms.var.copy(), float(vn.obs_rms.count))
        # the rollouts moved the rows: start PPO's collection from fresh episodes
        self.model._last_obs = self.training_env.reset()  # noqa: SLF001  (SB3's rollout state)
        self.model._last_episode_starts = np.ones((self.training_env.num_envs,), dtype=bool)  # noqa: SLF001
        if self.record_path is not None:
            Path(self.record_path).write_text(json.dumps(self.record, indent=1))
        if self.critic_warmup > 0:  # PPO's first updates move only the critic, towards the clone's own value
            self._frozen = self._parameters("pi+std")
            for p in self._frozen:
                p.requires_grad_(False)

    def _parameters(self, head: str) -> list[Any]:
        """The actor's layers (``"pi"``; with its noise: ``"pi+std"``) or the critic's (``"vf"``) of SB3's
        ``ActorCriticPolicy`` (``mlp_extractor.policy_net``, ``action_net``, ``log_std``; ``mlp_extractor.value_net``,
        ``value_net``)."""
        names = {"pi": ("policy_net", "action_net"), "pi+std": ("policy_net", "action_net", "log_std"),
                 "vf": ("value_net",)}[head]
        return [p for name, p in self.model.policy.named_parameters() if any(k in name for k in names)]

    def _on_rollout_start(self) -> None:
        if self._frozen and self.model.num_timesteps >= self.critic_warmup:
            for p in self._frozen:
                p.requires_grad_(True)
            self._frozen = []

    def _on_step(self) -> bool:
        if self._obs_stats is not None:  # undo VecNormalize's update of this step (module docstring)
            rms = self.model.get_vec_normalize_env().obs_rms
            rms.mean[...], rms.var[...], rms.count = self._obs_stats[0], self._obs_stats[1], self._obs_stats[2]
        return True
