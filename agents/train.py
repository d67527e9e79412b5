"""Train an SB3 agent on a vsa_gym environment, in rl-zoo3's layout, with checkpoints that resume exactly.

::

    python -m agents.train --env vsa_gym/ELPAS-ForceTracking-v0 --algo ppo --timesteps 200000 --seed 0 \\
        --log-folder logs
    python -m agents.train --env vsa_gym/ELPAS-ForceTracking-v0 --algo sac --timesteps 200000 --seed 0 \\
        --log-folder logs --resume            # continue the latest run of (env, algo, seed)

Hyperparameters come from ``agents/hyperparams/<algo>.yml`` (rl-zoo3 format, key = env id;
``--hyperparams FILE`` picks another file, ``--params key:value ...`` overrides entries).
Environments are the native batched vector envs (:func:`vsa_gym.envs.sb3.make_sb3_vec_env`)
under ``VecMonitor`` and ``VecNormalize``.

Runs are rl-zoo3's (``config.yml`` and ``args.yml`` in its format, :mod:`agents.zoo`): ``python -m rl_zoo3.enjoy
--algo ALGO --env ENV -f LOG --exp-id N --gym-packages vsa_gym`` loads them (the command is printed at the end).
Residual agents go to ``LOG/residual`` (:func:`agents.common.run_log_folder`), so their run ids never collide
with those of pure runs; rl-zoo3 reads them with ``-f LOG/residual``.

Checkpoints (``rl_model_N_steps.*``) hold the model with its step count, the VecNormalize
statistics and, for off-policy algorithms, the replay buffer.  They are written at the first
loop boundary (start of a rollout collection) after every ``--save-freq`` timesteps, at the end,
and on Ctrl-C: the first Ctrl-C stops at the next boundary after a checkpoint (a second one stops
at once, and the run resumes from the last checkpoint).  At a boundary every counted step's
transition is stored, so nothing is lost.  ``--resume`` loads the newest complete checkpoint
of the run and trains up to ``--timesteps`` in total; the step counter, TensorBoard curve,
replay buffer and normalisation continue.  Not restored: the environments restart with fresh
episodes (seeded from the seed and the step count), and the random number streams differ
from an uninterrupted run, so a resumed run is statistically, not bitwise, the same.

Periodic evaluation (``--eval-freq``) runs ``--eval-episodes`` deterministic episodes on the
validation seeds ``EVAL_SEED_BASE + k``, the same at every evaluation, and keeps ``best_model.zip``
(with ``best_model_vecnormalize.pkl``): the model of the evaluation with the highest mean return.
That return is scored with the training environment's arguments, i.e. the reward the agent was trained
for, as in rl-zoo3 (``--eval-reward training``; ``default`` drops the reward-only training arguments
such as a higher ``w_energy``, as :mod:`agents.evaluate` does), with the arguments of ``--eval-kwargs``
on top, e.g. ``"{failure_rate: 2.0}"``: a failure then also costs every step it skips, so a checkpoint
that ends validation episodes on a constraint cannot win by collecting less (negative) reward.  The metric
seeds of :mod:`agents.evaluate` (``METRIC_SEED_BASE + k``) stay unseen by both training and selection.
"""

from __future__ import annotations

import argparse
import os
import signal
import sys
import threading
import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from agents.common import (
    ALGO_NAMES,
    EVAL_SEED_BASE,
    OFF_POLICY,
    algo_class,
    checkpoints,
    env_name,
    hyperparams_file,
    make_callbacks,
    make_train_env,
    new_run_dir,
    process_hyperparams,
    read_hyperparams,
    read_json,
    read_yaml,
    run_dirs,
    run_log_folder,
    write_json,
    yaml_mapping,
)
from agents.zoo import write_args, zoo_args

_SEGMENTS = "train_info.json"


class _GracefulStopError(Exception):
    """Raised at a loop boundary after a checkpoint, when a stop (Ctrl-C) was requested."""


def _boundary_checkpoint(save_path: Path, save_freq: int, off_policy: bool, params_path: Path) -> Any:
    """Checkpoints at SB3's loop boundary, the start of a rollout collection.

    There every counted timestep's transition is in the replay buffer and the preceding
    gradient steps are done, so model, step count, buffer and statistics agree.  (SB3's
    ``CheckpointCallback`` saves inside ``on_step``, *before* that step's transition is stored:
    its replay buffers miss one transition per row at every checkpoint.)  A requested stop
    (:attr:`stop_requested`, set by the first Ctrl-C) also checkpoints there and ends training.
    """
    from stable_baselines3.common.callbacks import BaseCallback

    class BoundaryCheckpoint(BaseCallback):
        def __init__(self) -> None:
            super().__init__()
            self.stop_requested = False
            self.next_save = 0

        def _on_training_start(self) -> None:
            if save_freq > 0:
                self.next_save = (self.model.num_timesteps // save_freq + 1) * save_freq

        def _on_rollout_start(self) -> None:
            n = self.model.num_timesteps
            if (save_freq > 0 and n >= self.next_save) or self.stop_requested:
                save_checkpoint(self.model, save_path, off_policy, params_path)
                if save_freq > 0:
                    self.next_save = (n // save_freq + 1) * save_freq
            if self.stop_requested:
                raise _GracefulStopError

        def _on_step(self) -> bool:
            return True

    return BoundaryCheckpoint()


def _callbacks(save_path: Path, n_envs: int, eval_env: Any, eval_freq: int,
               eval_episodes: int, extra: Sequence[Any], resume: bool = False) -> list[Any]:
    from stable_baselines3.common.callbacks import BaseCallback, EvalCallback

    class SaveBestVecNormalize(BaseCallback):
        """Save the VecNormalize statistics that go with ``best_model.zip``."""

        def _on_step(self) -> bool:
            vn = self.model.get_vec_normalize_env()
            if vn is not None:
                vn.save(str(save_path / "best_model_vecnormalize.pkl"))
            return True

    class HeldOutEval(EvalCallback):
        """EvalCallback that reseeds the evaluation rows with the validation seeds before every evaluation,
        continues the evaluation record of a resumed run and evaluates the final model too."""

        def _init_callback(self) -> None:
            super()._init_callback()
            record = save_path / "evaluations.npz"
            if resume and record.exists():  # keep the record (and the best score) of the earlier segments
                with np.load(record) as ev:
                    self.evaluations_timesteps = [int(t) for t in ev["timesteps"]]
                    self.evaluations_results = [list(r) for r in ev["results"]]
                    self.evaluations_length = [list(n) for n in ev["ep_lengths"]]
                if self.evaluations_results:
                    self.best_mean_reward = float(max(np.mean(r) for r in self.evaluations_results))

        def _on_step(self) -> bool:
            if self.eval_freq > 0 and self.n_calls % self.eval_freq == 0:
                self.eval_env.seed(EVAL_SEED_BASE)
            return super()._on_step()

        def evaluate_final(self) -> None:
            """One more evaluation at the end of training (unless the last one was at this step), so that
            ``best_model.zip`` is the best of the periodic evaluations *and* the final model."""
            if self.evaluations_timesteps and self.evaluations_timesteps[-1] == self.model.num_timesteps:
                return
            self.n_calls = (self.n_calls // self.eval_freq + 1) * self.eval_freq - 1
            self.on_step()  # n_calls += 1 -> a multiple of eval_freq: evaluates now

    cbs: list[Any] = []
    if eval_env is not None and eval_freq > 0:
        cbs.append(HeldOutEval(eval_env, callback_on_new_best=SaveBestVecNormalize(),
                               best_model_save_path=str(save_path), log_path=str(save_path),
                               eval_freq=max(eval_freq // n_envs, 1), n_eval_episodes=eval_episodes,
                               deterministic=True, verbose=0))
    cbs.extend(extra)
    return cbs


def save_checkpoint(model: Any, save_path: Path, off_policy: bool, params_path: Path | None = None) -> Path:
    """Write ``rl_model_<N>_steps`` (model, VecNormalize, replay buffer) at the model's current step count.

    ``params_path`` (``SAVE_PATH/ENV_NAME``): also the statistics there as ``vecnormalize.pkl``, which rl-zoo3's
    loaders use with every model of a run (also ``--load-checkpoint`` and ``--load-best``), so that they can read
    an interrupted run too.
    """
    n = int(model.num_timesteps)
    zip_path = save_path / f"rl_model_{n}_steps.zip"
    if off_policy and getattr(model, "replay_buffer", None) is not None:
        model.save_replay_buffer(str(save_path / f"rl_model_replay_buffer_{n}_steps.pkl"))
    vn = model.get_vec_normalize_env()
    if vn is not None:
        vn.save(str(save_path / f"rl_model_vecnormalize_{n}_steps.pkl"))
        if params_path is not None:
            vn.save(str(params_path / "vecnormalize.pkl"))
    model.save(str(zip_path))  # written last: a checkpoint counts once its zip exists
    return zip_path


def _find_resume_dir(log_folder: Path, algo: str, env_id: str, seed: int) -> Path:
    for d in reversed(run_dirs(log_folder, algo, env_id)):
        args = d / env_name(env_id) / "args.yml"
        if args.exists() and int((read_yaml(args) or {}).get("seed", -1)) == seed:
            return d
    raise FileNotFoundError(f"no run of {algo} on {env_id} with seed {seed} under {log_folder} to resume "
                            "(residual runs are under LOG/residual: give the hyperparameters they were trained with, "
                            "or --resume RUN_DIR)")


def train(env_id: str, algo: str = "ppo", timesteps: int | None = None, seed: int = 0,
          log_folder: str | os.PathLike[str] = "logs", resume: bool | str | os.PathLike[str] = False,
          hyperparams: str | os.PathLike[str] | None = None, params: Mapping[str, Any] | None = None,
          save_freq: int = 50_000, eval_freq: int = 25_000, eval_episodes: int = 4, n_eval_envs: int | None = None,
          tensorboard: bool = True, progress_bar: bool = False, num_threads: int = 1, device: str = "cpu",
          verbose: int = 0, callbacks: Sequence[Any] = (), eval_reward: str = "training",
          eval_kwargs: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """Train (or resume) one agent; returns the run summary (also in ``SAVE_PATH/train_info.json``).

    ``resume``: ``True`` continues the newest run of (env, algo, seed) under ``log_folder``, a path
    continues that run directory.  Residual agents (a ``vec_env_wrapper`` of :mod:`agents.residual` in the
    hyperparameters) go to ``log_folder/residual`` (:func:`agents.common.run_log_folder`), also when resuming.
    ``callbacks`` are extra SB3 callbacks (tests use them to interrupt).
    Periodic evaluation (``eval_freq`` > 0): ``eval_episodes`` episodes on ``n_eval_envs`` rows (default:
    one row per episode), scored under ``eval_reward`` (``"default"`` or ``"training"``) with
    ``eval_kwargs`` applied last (module docstring).
    """
    import torch

    import vsa_gym.envs  # noqa: F401

    algo = algo.lower()
    if algo not in ALGO_NAMES:
        raise ValueError(f"algo must be one of {ALGO_NAMES}, got {algo!r}")
    if num_threads > 0:
        torch.set_num_threads(num_threads)
    cpu0, wall0 = time.process_time(), time.perf_counter()
    log_folder = Path(log_folder)
    off_policy = algo in OFF_POLICY
    cls = algo_class(algo)

    if resume:
        if isinstance(resume, bool):
            wrapper = read_hyperparams(algo, env_id, hyperparams, params).get("vec_env_wrapper")
            save_path = _find_resume_dir(run_log_folder(log_folder, wrapper), algo, env_id, seed)
        else:
            save_path = Path(resume)
        params_path = save_path / env_name(env_id)
        raw = dict(read_yaml(params_path / "config.yml") or {})
        seed = int((read_yaml(params_path / "args.yml") or {})["seed"])
        run_log = save_path.parent.parent
    else:
        raw = read_hyperparams(algo, env_id, hyperparams, params)
        run_log = run_log_folder(log_folder, raw.get("vec_env_wrapper"), new_run=True)
        save_path = new_run_dir(run_log, algo, env_id)
        params_path = save_path / env_name(env_id)
    hp = process_hyperparams(raw, n_actions=_n_actions(env_id, raw.get("env_kwargs")))
    total = int(timesteps) if timesteps is not None else hp["n_timesteps"]
    n_envs = hp["n_envs"]
    normalized = hp["normalize"] is not None
    params_path.mkdir(parents=True, exist_ok=True)

    start_steps, ckpt = 0, None
    if resume:
        found = checkpoints(save_path, off_policy, normalized)
        if not found:
            raise FileNotFoundError(f"{save_path} has no complete checkpoint to resume from")
        start_steps, ckpt = found[-1]
        if start_steps >= total:
            print(f"{save_path}: already at {start_steps} >= {total} timesteps; nothing to do")
    else:
        (params_path / "config.yml").write_text(yaml.dump(dict(sorted(raw.items()))))
        write_args(params_path / "args.yml", zoo_args({
            "algo": algo, "env": env_id, "seed": seed, "n_timesteps": total, "log_folder": str(run_log),
            "conf_file": str(hyperparams_file(algo, hyperparams)), "hyperparams": dict(params) if params else None,
            "save_freq": save_freq, "eval_freq": eval_freq, "eval_episodes": eval_episodes,
            "n_eval_envs": int(n_eval_envs or eval_episodes), "eval_reward": eval_reward,
            "eval_kwargs": dict(eval_kwargs or {}), "device": device, "num_threads": num_threads,
            "verbose": verbose, "progress": progress_bar,
            "tensorboard_log": str(save_path / "tb") if tensorboard else ""}, raw))
        (params_path / "command.txt").write_text(" ".join(getattr(sys, "orig_argv", sys.argv)))

    env_seed = seed
    if resume:  # fresh episodes after a resume, on streams unrelated to the held-out seeds
        env_seed = int(np.random.SeedSequence([seed, start_steps]).generate_state(1)[0] >> 1)
    monitor = str(save_path / (f"resume_{start_steps}" if resume else "0"))
    vn_path = save_path / f"rl_model_vecnormalize_{start_steps}_steps.pkl" if (resume and normalized) else None
    env = make_train_env(env_id, n_envs, env_seed, hp["env_kwargs"], hp["normalize"], monitor, vn_path,
                         vec_env_wrapper=hp["vec_env_wrapper"], frame_stack=hp["frame_stack"])
    eval_env = None
    if eval_freq > 0:
        from agents.evaluate import scoring_env_kwargs

        eval_env_kwargs = scoring_env_kwargs(env_id, hp["env_kwargs"] or {}, eval_reward, eval_kwargs)[0]
        eval_env = make_train_env(env_id, int(n_eval_envs or eval_episodes), EVAL_SEED_BASE, eval_env_kwargs,
                                  hp["normalize"], training=False, vec_env_wrapper=hp["vec_env_wrapper"],
                                  frame_stack=hp["frame_stack"])
    tb = str(save_path / "tb") if tensorboard else None
    if resume:
        model = cls.load(str(ckpt), env=env, device=device, tensorboard_log=tb)
        model.set_random_seed(env_seed)
        if off_policy:
            model.load_replay_buffer(str(save_path / f"rl_model_replay_buffer_{start_steps}_steps.pkl"))
    else:
        model = cls(env=env, seed=seed, device=device, tensorboard_log=tb, verbose=verbose, **hp["model"])

    ckpt_cb = _boundary_checkpoint(save_path, save_freq, off_policy, params_path)
    zoo_cbs = make_callbacks(hp["callback"])  # the hyperparameters' ``callback`` entry, as rl-zoo3 builds it
    for cb in zoo_cbs:
        if getattr(cb, "record_path", "") is None:  # e.g. agents.warm_start: its record goes into the run
            cb.record_path = str(save_path / "warm_start.json")
    cbs = [ckpt_cb, *zoo_cbs,
           *_callbacks(save_path, n_envs, eval_env, eval_freq, eval_episodes, callbacks, bool(resume))]
    status = "finished"
    remaining = max(total - int(model.num_timesteps), 0)
    previous = None
    if threading.current_thread() is threading.main_thread():
        def on_sigint(signum: int, frame: Any) -> None:
            if ckpt_cb.stop_requested:  # second Ctrl-C: stop now, resume from the last checkpoint
                raise KeyboardInterrupt
            ckpt_cb.stop_requested = True
            print("\nstopping at the next rollout boundary after a checkpoint (Ctrl-C again: stop now)",
                  file=sys.stderr)

        previous = signal.signal(signal.SIGINT, on_sigint)
    try:
        if remaining > 0:
            model.learn(remaining, callback=cbs, reset_num_timesteps=not resume, tb_log_name=algo.upper(),
                        progress_bar=progress_bar)
            for cb in cbs:
                if hasattr(cb, "evaluate_final"):
                    cb.evaluate_final()
    except _GracefulStopError:
        status = "interrupted"
        print(f"interrupted at {model.num_timesteps} timesteps; checkpoint saved, continue with --resume",
              file=sys.stderr)
    except KeyboardInterrupt:
        status = "interrupted"  # mid-step: no checkpoint of this state, resume uses the last one
        print("interrupted; continue with --resume from the last checkpoint", file=sys.stderr)
    except BaseException:
        status = "failed"  # no checkpoint of a possibly inconsistent state: resume uses the last periodic one
        raise
    finally:
        if previous is not None:
            signal.signal(signal.SIGINT, previous)
        if status == "finished":
            save_checkpoint(model, save_path, off_policy, params_path)
            model.save(str(save_path / env_name(env_id)))
        env.close()
        if eval_env is not None:
            eval_env.close()
        info = read_json(save_path / _SEGMENTS, {"segments": []})
        info["segments"].append({"start": start_steps, "end": int(model.num_timesteps), "status": status,
                                 "cpu_s": time.process_time() - cpu0, "wall_s": time.perf_counter() - wall0})
        info.update({"env_id": env_id, "algo": algo, "seed": seed, "target_timesteps": total,
                     "num_timesteps": int(model.num_timesteps), "status": status,
                     "cpu_s": sum(s["cpu_s"] for s in info["segments"]),
                     "wall_s": sum(s["wall_s"] for s in info["segments"]),
                     "save_path": str(save_path), "log_folder": str(run_log),
                     "model": str(save_path / f"{env_name(env_id)}.zip")})
        write_json(save_path / _SEGMENTS, info)
    return info


def _n_actions(env_id: str, env_kwargs: Any) -> int:
    import gymnasium as gym

    spec = gym.spec(env_id)
    env = spec.make(**(env_kwargs if isinstance(env_kwargs, dict) else {}))
    n = int(env.action_space.shape[0])
    env.close()
    return n


def with_residual(params: Mapping[str, Any], spec: str) -> dict[str, Any]:
    """``params`` plus the overrides of ``--residual BASELINE[:SCALE]`` (env_kwargs are merged, not replaced)."""
    from agents.residual import residual_params

    name, _, scale = spec.partition(":")
    extra = residual_params(name, float(scale) if scale else 0.3)
    out = dict(params)
    kw = extra.pop("env_kwargs", None)
    if kw:
        out["env_kwargs"] = {**dict(out.get("env_kwargs") or {}), **kw}
    out.update(extra)
    return out


def parse_params(items: Sequence[str]) -> dict[str, Any]:
    out = {}
    for it in items:
        if ":" not in it:
            raise argparse.ArgumentTypeError(f"--params takes key:value pairs, got {it!r}")
        k, v = it.split(":", 1)
        out[k] = yaml.safe_load(v)
    return out


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m agents.train", description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--env", required=True, help="registered id, e.g. vsa_gym/ELPAS-ForceTracking-v0")
    ap.add_argument("--algo", default="ppo", choices=ALGO_NAMES)
    ap.add_argument("--timesteps", "-n", type=int, default=None, help="total timesteps (default: n_timesteps)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--log-folder", "-f", default="logs")
    ap.add_argument("--resume", nargs="?", const=True, default=False, metavar="RUN_DIR",
                    help="continue the newest run of (env, algo, seed), or the given run directory")
    ap.add_argument("--hyperparams", "-conf", default=None, help="rl-zoo3 YAML (default agents/hyperparams/ALGO.yml)")
    ap.add_argument("--params", nargs="*", default=[], help="overrides, key:value (YAML values)")
    ap.add_argument("--residual", default=None, metavar="BASELINE[:SCALE]",
                    help="residual RL over a baseline (cascade, skyhook, passive, decoupled), correction scale "
                         "default 0.3: see agents/residual.py")
    ap.add_argument("--save-freq", type=int, default=50_000, help="checkpoint period in timesteps (<= 0: off)")
    ap.add_argument("--eval-freq", type=int, default=25_000, help="evaluation period in timesteps (<= 0: off)")
    ap.add_argument("--eval-episodes", type=int, default=4)
    ap.add_argument("--n-eval-envs", type=int, default=None,
                    help="rows of the evaluation env (default: one per episode)")
    ap.add_argument("--eval-reward", choices=("default", "training"), default="training",
                    help="reward the periodic evaluation (best_model.zip) is scored with")
    ap.add_argument("--eval-kwargs", type=yaml_mapping, default=None, metavar="YAML",
                    help='environment arguments of the evaluation env on top, e.g. "{failure_rate: 2.0}"')
    ap.add_argument("--no-tensorboard", action="store_true")
    ap.add_argument("--no-progress-bar", action="store_true")
    ap.add_argument("--num-threads", type=int, default=1, help="torch threads (<= 0: torch's default)")
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--verbose", type=int, default=0)
    a = ap.parse_args(argv)
    params = parse_params(a.params)
    if a.residual:
        params = with_residual(params, a.residual)
    info = train(a.env, a.algo, a.timesteps, a.seed, a.log_folder, a.resume, a.hyperparams, params,
                 a.save_freq, a.eval_freq, a.eval_episodes, a.n_eval_envs, not a.no_tensorboard,
                 not a.no_progress_bar, a.num_threads, a.device, a.verbose, eval_reward=a.eval_reward,
                 eval_kwargs=a.eval_kwargs)
    print(f"{info['status']}: {info['num_timesteps']} timesteps, {info['cpu_s'] / 60:.2f} CPU min -> "
          f"{info['save_path']}")
    run_id = Path(info["save_path"]).name.rsplit("_", 1)[1]
    print(f"rl-zoo3: python -m rl_zoo3.enjoy --algo {a.algo} --env {a.env} -f {info['log_folder']} "
          f"--exp-id {run_id} --gym-packages vsa_gym --no-render")
    return 0 if info["status"] == "finished" else 130


if __name__ == "__main__":
    sys.exit(main())
