"""Evaluate a trained agent with the baselines' metrics (:func:`baselines.metrics.evaluate_policy`).

::

    python -m agents.evaluate logs/ppo/vsa_gym-ELPAS-ForceTracking-v0_1/vsa_gym-ELPAS-ForceTracking-v0.zip \\
        --env vsa_gym/ELPAS-ForceTracking-v0 --episodes 10 --json metrics.json   # -> next to the model

The model's algorithm is read from the .zip (``--algo`` overrides) and its VecNormalize statistics
are found by the run layout (:func:`run_vecnormalize`; ``--vecnormalize`` overrides).
The policy is deterministic.  Episodes use the seeds ``--seed-base + k`` (default
``METRIC_SEED_BASE``, never used in training) and the environment arguments the agent was trained
with (its ``config.yml``, replaced by the ``env_kwargs`` of ``args.yml`` where rl-zoo3's ``--env-kwargs`` put
them, as ``rl_zoo3.enjoy`` reads them), so a learned policy and a baseline are measured by the same rules on the
same episodes.  Runs of ``python -m rl_zoo3.train`` load like ours (same layout; their ``OrderedDict`` YAML is read
by :func:`agents.common.read_yaml`).  ``--json FILE`` writes the metrics dict of ``evaluate_policy`` plus a
``"agent"`` entry; a relative ``FILE`` is taken relative to the model's folder (the run directory), never the
current directory.

**Reward.**  The physical metrics (tracking RMS, comfort, energy, violations) do not depend on the
reward, but the ``return`` does.  An agent may be trained with other reward weights (e.g.
``env_kwargs: {w_energy: 0.01}``, a higher energy price); its return is then reported under the
environment's **default** reward (``--reward default``, the default): the reward-only arguments of
:data:`REWARD_KWARGS` are removed from the training ``env_kwargs`` before the evaluation, so every
policy's return in a table is the same function of the same episodes; so are the drive protections an agent
trained without (:data:`PROTECTION_KWARGS`: every policy is scored on the drive as registered).
``--reward training`` keeps them (the return the agent was trained for).  ``agent.training_reward_kwargs``
in the JSON names what was removed.
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from agents.common import (
    METRIC_SEED_BASE,
    algo_class,
    algo_of_model,
    eval_zoo_expr,
    frame_stack_of,
    is_recurrent,
    read_vecnormalize,
    run_config,
    run_env_kwargs,
    run_params_dir,
    vecnormalize_for,
    write_json,
    yaml_mapping,
)
from agents.features import FEATURE_CLASS, feature_config, feature_policy
from agents.hold import HOLD_CLASS, hold_config, hold_policy
from agents.residual import RESIDUAL_CLASS, SETPOINT_CLASS, residual_config, residual_policy

REWARD_KWARGS: dict[str, frozenset[str]] = {
    "vsa_gym/ELPAS-ForceTracking-v0": frozenset({"w_force", "w_energy", "force_scale", "failure_penalty",
                                                 "failure_rate", "episode_steps", "regen", "w_stop",
                                                 "stop_width"}),
    "vsa_gym/ELPAS-QuarterCar-v0": frozenset({"w_comfort", "w_travel", "w_tyre", "w_energy", "accel_scale",
                                              "travel_soft", "failure_penalty", "failure_rate", "episode_steps",
                                              "regen"}),
    "vsa_gym/VsaUT2-PositionStiffness-v0": frozenset({"w_position", "w_stiffness", "w_energy", "position_scale",
                                                      "log_stiffness_scale", "failure_penalty", "failure_rate",
                                                      "episode_steps", "regen"}),
    # the throw's progress shaping (potential-based: the policy's optimum and the score are unchanged) is a
    # training aid: scored without it, the return is the release speed less the failure charge
    "vsa_gym/VsaUT2-Throw-v0": frozenset({"failure_penalty", "shaping", "shaping_gamma"}),
}
"""Environment arguments that change only the reward (and ``energy_charged``, the energy term's basis),
never the dynamics, observations or episode ends; ``tests/agents/test_evaluate_reward.py`` checks this
for every registered id.  (``regen`` is reward-only on the eLPAS and the vsaUT-II position task; on the
throw it decides how fast the energy budget is spent, so it is not listed there.)"""

_ELPAS_PROTECTION = frozenset({"soft_limit", "soft_limit_decel"})
PROTECTION_KWARGS: dict[str, frozenset[str]] = {
    "vsa_gym/ELPAS-ForceTracking-v0": _ELPAS_PROTECTION,
    "vsa_gym/ELPAS-QuarterCar-v0": _ELPAS_PROTECTION,
}
"""The drive's own protections (the eLPAS software travel limit): the scored task always has them at the
environment's defaults.  An agent may train without one (``soft_limit: null``: a stop it reaches then ends the
training episode and is charged); scored under the default reward it runs with the drive as registered, like
every baseline.  These do change the dynamics near the stops, so they are listed apart from :data:`REWARD_KWARGS`
and dropped together with them."""

REWARD_MODES = ("default", "training")


def split_reward_kwargs(env_id: str, env_kwargs: Mapping[str, Any]) -> tuple[dict[str, Any], dict[str, Any]]:
    """``(env_kwargs without the training-only arguments, those arguments)`` of ``env_id``: the reward-only ones
    (:data:`REWARD_KWARGS`) and the drive protections (:data:`PROTECTION_KWARGS`)."""
    if env_id not in REWARD_KWARGS:
        raise ValueError(f"no list of reward-only arguments for {env_id!r} (agents.evaluate.REWARD_KWARGS); "
                         "evaluate with reward='training'")
    keys = REWARD_KWARGS[env_id] | PROTECTION_KWARGS.get(env_id, frozenset())
    return ({k: v for k, v in env_kwargs.items() if k not in keys},
            {k: v for k, v in env_kwargs.items() if k in keys})


def scoring_env_kwargs(env_id: str, env_kwargs: Mapping[str, Any], reward: str = "default",
                       extra: Mapping[str, Any] | None = None) -> tuple[dict[str, Any], dict[str, Any]]:
    """``(env_kwargs to score a policy with, the training-only arguments dropped)``.

    ``reward="default"`` removes the reward-only arguments of :data:`REWARD_KWARGS` and the drive protections of
    :data:`PROTECTION_KWARGS` from the training ``env_kwargs`` (the environment's default reward and drive),
    ``"training"`` keeps them; ``extra`` applies last in
    both cases.  Used by :func:`evaluate_agent` and by the periodic evaluation of :func:`agents.train.train`.
    """
    if reward not in REWARD_MODES:
        raise ValueError(f"reward must be one of {REWARD_MODES}, got {reward!r}")
    kw, dropped = dict(env_kwargs), {}
    if reward == "default" and kw:
        kw, dropped = split_reward_kwargs(env_id, kw)
    kw.update(extra or {})
    return kw, dropped


class SB3Policy:
    """A trained SB3 model as a baselines policy: ``reset()``, ``policy(obs) -> action`` (batched or single).

    Observations are normalised with the frozen training statistics (``obs_rms``, ``clip_obs``,
    ``epsilon`` of the saved ``VecNormalize``) exactly as ``VecNormalize.normalize_obs`` does.  With
    ``frame_stack`` = n > 1 the model sees the last n normalised observations side by side, oldest first and
    zeros before the episode's first, as SB3's ``VecFrameStack`` (after ``VecNormalize``, rl-zoo3's order)
    gave them in training.  A recurrent model (sb3-contrib's ``RecurrentPPO``, rl-zoo3's ``ppo_lstm``) carries
    its LSTM state from call to call, from zero at an episode's first observation, as SB3's
    ``evaluate_policy`` runs it.  ``reset()`` starts a new episode for every row.
    """

    def __init__(self, model: Any, vecnormalize: Any | None = None, deterministic: bool = True,
                 frame_stack: int = 1) -> None:
        self.model = model
        self.vecnormalize = vecnormalize
        self.deterministic = deterministic
        self.frame_stack = int(frame_stack)
        self.frames: np.ndarray | None = None
        self.recurrent = is_recurrent(model.policy)
        self.state: Any = None

    def reset(self) -> None:
        """Forget the stacked frames and the recurrent state (no-ops for a plain MLP policy)."""
        self.frames = None
        self.state = None

    def normalize(self, obs: np.ndarray) -> np.ndarray:
        vn = self.vecnormalize
        if vn is None or not vn.norm_obs:
            return obs
        return vn.normalize_obs(obs)

    def stack(self, obs: np.ndarray) -> np.ndarray:
        """``obs`` (n, d) appended to each row's frames: (n, frame_stack d)."""
        if self.frame_stack <= 1:
            return obs
        n, d = obs.shape
        if self.frames is None or self.frames.shape != (n, self.frame_stack * d):
            self.frames = np.zeros((n, self.frame_stack * d), dtype=obs.dtype)
        self.frames = np.concatenate([self.frames[:, d:], obs], axis=1)
        return self.frames

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        o = np.asarray(obs, dtype=np.float32)
        single = o.ndim == 1
        o2 = np.atleast_2d(o)
        x = self.stack(self.normalize(o2))
        if self.recurrent:
            if self.state is not None and self.state[0].shape[1] != o2.shape[0]:
                self.state = None  # another batch of rows: new episodes
            start = np.full(o2.shape[0], self.state is None)
            action, self.state = self.model.predict(x, state=self.state, episode_start=start,
                                                    deterministic=self.deterministic)
        else:
            action, _ = self.model.predict(x, deterministic=self.deterministic)
        action = np.asarray(action, dtype=np.float32)
        return action[0] if single else action


def load_agent(model_path: str | os.PathLike[str], algo: str | None = None,
               vecnormalize: str | os.PathLike[str] | None = None, deterministic: bool = True,
               frame_stack: int | None = None) -> SB3Policy:
    """Load a model .zip of the run layout with its VecNormalize statistics as an :class:`SB3Policy`
    (``deterministic=False``: it samples its actions, with the exploration noise it was trained with;
    ``frame_stack``: how many observations it sees side by side, default its run's, :func:`training_frame_stack`)."""
    model_path = Path(model_path)
    algo = algo or algo_of_model(model_path)
    model = algo_class(algo).load(str(model_path), device="cpu")
    vn_path = Path(vecnormalize) if vecnormalize is not None else vecnormalize_for(model_path)
    vn = None
    if vn_path is not None:
        vn = read_vecnormalize(vn_path)
        vn.training = False
    n_stack = training_frame_stack(model_path) if frame_stack is None else frame_stack_of(frame_stack)
    return SB3Policy(model, vn, deterministic, n_stack)


def training_env_kwargs(model_path: str | os.PathLike[str], env_id: str) -> dict[str, Any]:
    """The run's environment arguments (:func:`agents.common.run_env_kwargs`; empty outside a run directory)."""
    params_dir = run_params_dir(model_path, env_id)
    return run_env_kwargs(params_dir) if params_dir is not None else {}


def training_vec_env_wrapper(model_path: str | os.PathLike[str], env_id: str) -> Any:
    """``vec_env_wrapper`` of the run's ``config.yml`` (``None`` when absent or outside a run directory)."""
    params_dir = run_params_dir(model_path, env_id)
    return run_config(params_dir).get("vec_env_wrapper") if params_dir is not None else None


def training_frame_stack(model_path: str | os.PathLike[str], env_id: str | None = None) -> int:
    """``frame_stack`` of the run's ``config.yml`` (1, no stacking, when absent or outside a run directory).
    Without ``env_id`` every ``config.yml`` one level below the model's folder is read (the run layout keeps
    one, in ``ENV_NAME/``); ``ValueError`` if they disagree."""
    if env_id is not None:
        params_dir = run_params_dir(model_path, env_id)
        dirs = [] if params_dir is None else [params_dir]
    else:
        dirs = [c.parent for c in sorted(Path(model_path).parent.glob("*/config.yml"))]
    found = {frame_stack_of(run_config(d).get("frame_stack")) for d in dirs}
    if len(found) > 1:
        raise ValueError(f"{model_path}: the config.yml files next to the model name different frame_stack "
                         f"values {sorted(found)}; pass frame_stack (or env_id) explicitly")
    return found.pop() if found else 1


def run_vecnormalize(model_path: str | os.PathLike[str], env_id: str) -> Path | None:
    """The VecNormalize statistics of a model: its own (:func:`agents.common.vecnormalize_for`), else the run's
    ``ENV_NAME/vecnormalize.pkl``, which is what rl-zoo3 uses with every model of a run (its checkpoints and
    ``best_model.zip`` have no statistics of their own).  ``ValueError`` when the run normalised its observations
    and neither exists: the policy would see unnormalised ones."""
    own = vecnormalize_for(model_path)
    if own is not None:
        return own
    params_dir = run_params_dir(model_path, env_id)
    if params_dir is None:
        return None
    if (params_dir / "vecnormalize.pkl").exists():
        return params_dir / "vecnormalize.pkl"
    norm = run_config(params_dir).get("normalize")
    norm = eval_zoo_expr(norm) if isinstance(norm, str) else norm
    if norm is True or (isinstance(norm, Mapping) and norm.get("norm_obs", True)):
        raise ValueError(f"{model_path}: the run was trained with normalize but {params_dir}/vecnormalize.pkl "
                         "does not exist; pass the statistics with --vecnormalize")
    return None


def json_path(model_path: str | os.PathLike[str], path: str | os.PathLike[str]) -> Path:
    """Where ``--json path`` goes: ``path`` if absolute, else relative to the model's folder (the run directory)."""
    p = Path(path).expanduser()
    return p if p.is_absolute() else Path(model_path).resolve().parent / p


def wrapped_policy(agent: Any, vec_env_wrapper: Any) -> Any:
    """``policy_factory(env)`` that feeds ``agent`` what it saw in training: the ``vec_env_wrapper`` entries of
    its run (residual baseline, observation features) rebuilt as policies, innermost wrapper outermost."""
    factory: Any = lambda env: agent  # noqa: E731
    items = [] if vec_env_wrapper is None else (vec_env_wrapper if isinstance(vec_env_wrapper, list)
                                                else [vec_env_wrapper])
    for it in reversed(items):
        path, kw = next(iter(it.items())) if isinstance(it, Mapping) else (it, {})
        kw = dict(kw or {})
        if path in (RESIDUAL_CLASS, SETPOINT_CLASS):
            factory = residual_policy(None, residual_config([{path: kw}]) or {}, agent_factory=factory)
        elif path == FEATURE_CLASS:
            factory = feature_policy(factory, kw)
        elif path == HOLD_CLASS:
            factory = hold_policy(factory, kw)
        else:
            raise ValueError(f"agents.evaluate cannot rebuild the vec_env_wrapper {path!r} as a policy")
    return factory


def evaluate_agent(model_path: str | os.PathLike[str], env_id: str, episodes: int = 10,
                   seed_base: int = METRIC_SEED_BASE, algo: str | None = None,
                   vecnormalize: str | os.PathLike[str] | None = None, episode_steps: int | None = None,
                   env_kwargs: Mapping[str, Any] | None = None, reward: str = "default",
                   deterministic: bool = True) -> dict[str, Any]:
    """The baselines' metrics of a trained agent on ``episodes`` held-out seeds.

    ``deterministic=False`` samples the actions (the policy's exploration noise, as in training; the noise
    stream is seeded with ``seed_base``): what the agent's training rollouts look like.
    A residual agent (``vec_env_wrapper`` of :mod:`agents.residual` in its ``config.yml``) is
    evaluated as the composition baseline + scaled correction it was trained as.  ``reward="default"``
    drops the reward-only training arguments (module docstring), ``"training"`` keeps them;
    ``env_kwargs`` given here apply last in both cases.
    """
    from baselines.metrics import evaluate_policy

    factory, kw, agent = agent_policy(model_path, env_id, algo, vecnormalize, env_kwargs, reward, deterministic)
    if not deterministic:
        import torch

        torch.manual_seed(int(seed_base))
    seeds = [seed_base + k for k in range(int(episodes))]
    result = evaluate_policy(env_id, factory, seeds, episode_steps=episode_steps, env_kwargs=kw or None)
    result = dict(result)
    result["agent"] = {"model": agent["model"], "algo": agent["algo"], "vecnormalize": agent["vecnormalize"],
                       "seeds": seeds, "env_kwargs": kw, "residual": agent["residual"],
                       "features": agent["features"], "hold": agent["hold"],
                       "frame_stack": agent["frame_stack"], "reward": reward,
                       "training_reward_kwargs": agent["training_reward_kwargs"], "deterministic": deterministic}
    return result


def agent_policy(model_path: str | os.PathLike[str], env_id: str, algo: str | None = None,
                 vecnormalize: str | os.PathLike[str] | None = None, env_kwargs: Mapping[str, Any] | None = None,
                 reward: str = "default", deterministic: bool = True) -> tuple[Any, dict[str, Any], dict[str, Any]]:
    """``(policy_factory, env_kwargs, description)``: a trained agent as :func:`evaluate_agent` runs it (frozen
    VecNormalize statistics, the run's wrappers rebuilt as policies) and the environment arguments to run it
    with (the run's, reward-only ones dropped under ``reward="default"``, ``env_kwargs`` on top; no time limit
    of the training env).  ``description`` names the model, algorithm, statistics and wrappers."""
    vn_path = Path(vecnormalize) if vecnormalize is not None else run_vecnormalize(model_path, env_id)
    frame_stack = training_frame_stack(model_path, env_id)
    policy = load_agent(model_path, algo, vn_path, deterministic, frame_stack)
    kw, dropped = scoring_env_kwargs(env_id, training_env_kwargs(model_path, env_id), reward, env_kwargs)
    kw.pop("max_episode_steps", None)  # metrics run the registered episode length unless episode_steps is given
    wrappers = training_vec_env_wrapper(model_path, env_id)
    description = {"model": str(model_path), "algo": algo or algo_of_model(model_path), "vecnormalize": str(vn_path),
                   "residual": residual_config(wrappers), "features": feature_config(wrappers),
                   "hold": hold_config(wrappers), "frame_stack": frame_stack, "training_reward_kwargs": dropped}
    return wrapped_policy(policy, wrappers), kw, description


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m agents.evaluate", description=__doc__.split("\n\n")[0])
    ap.add_argument("model", help="model .zip (final, checkpoint or best_model)")
    ap.add_argument("--env", required=True)
    ap.add_argument("--episodes", type=int, default=10)
    ap.add_argument("--json", default=None, metavar="FILE",
                    help="write the metrics here; a relative FILE is relative to the model's folder (the run "
                         "directory), not the current directory")
    ap.add_argument("--seed-base", type=int, default=METRIC_SEED_BASE)
    ap.add_argument("--algo", default=None)
    ap.add_argument("--vecnormalize", default=None)
    ap.add_argument("--episode-steps", type=int, default=None, help="shorter episodes (default: the time limit)")
    ap.add_argument("--reward", choices=REWARD_MODES, default="default",
                    help="return under the environment's default reward (default) or the training reward weights")
    ap.add_argument("--env-kwargs", type=yaml_mapping, default=None, metavar="YAML",
                    help="environment arguments on top of the training ones, e.g. a stress set "
                         '"{force_range: [2800, 3200]}" or "{sensor_noise: true}"')
    a = ap.parse_args(argv)
    res = evaluate_agent(a.model, a.env, a.episodes, a.seed_base, a.algo, a.vecnormalize, a.episode_steps,
                         env_kwargs=a.env_kwargs, reward=a.reward)
    if a.json:
        out = json_path(a.model, a.json)
        write_json(out, res)
        print(f"wrote {out}", file=sys.stderr)
    print(yaml.safe_dump({k: v for k, v in res.items() if not isinstance(v, list | dict)}, sort_keys=False)
          or str(res))
    return 0


if __name__ == "__main__":
    sys.exit(main())
