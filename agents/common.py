"""Shared pieces of the agents: algorithms, rl-zoo3 hyperparameter files, environments and the run layout.

Run layout (rl-zoo3's, so that ``rl_zoo3.enjoy`` and our tools read each other's runs)::

    LOG_FOLDER/ALGO/ENV_NAME_RUNID/              "save path"; ENV_NAME is the id with "/" -> "-"
        ENV_NAME.zip                             final model
        ENV_NAME/vecnormalize.pkl                VecNormalize statistics of the newest checkpoint (final at the end)
        ENV_NAME/config.yml, args.yml, command.txt   rl-zoo3's files (:mod:`agents.zoo`), plain YAML
        rl_model_N_steps.zip                     checkpoints (N = timesteps), with
        rl_model_vecnormalize_N_steps.pkl        their VecNormalize statistics and
        rl_model_replay_buffer_N_steps.pkl       replay buffer (off-policy algorithms)
        best_model.zip, best_model_vecnormalize.pkl, evaluations.npz   periodic evaluation
        0.monitor.csv                            training episodes
        tb/                                      TensorBoard logs
        train_info.json                          timesteps, CPU and wall seconds per segment (ours)

Residual runs (a ``vec_env_wrapper`` of :mod:`agents.residual`) go to ``LOG_FOLDER/residual/ALGO/...``
(:func:`run_log_folder`), so they never share run ids with the pure runs of the same (algo, env); rl-zoo3 reads
them with ``-f LOG_FOLDER/residual``.  rl-zoo3's own ``config.yml`` and ``args.yml`` are ``OrderedDict`` dumps:
:func:`read_yaml` (:class:`ZooLoader`) reads them without unsafe loading.

Seeds: a run with ``--seed S`` seeds the model and the training rows with ``S, S+1, ...``;
periodic evaluation uses the held-out seeds ``EVAL_SEED_BASE + k`` (the same at every
evaluation), final metrics ``METRIC_SEED_BASE + k``; ``DEV_SEED_BASE + k`` is a development set for choosing
between settings (``benchmarks.agents_dev``), which neither model selection nor the table's test episodes use.
Training never resets with these.
"""

from __future__ import annotations

import json
import os
import re
import zipfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import yaml

ALGO_NAMES: tuple[str, ...] = ("ppo", "sac", "td3", "tqc", "ppo_lstm")
OFF_POLICY: frozenset[str] = frozenset({"sac", "td3", "tqc"})
HYPERPARAMS_DIR = Path(__file__).resolve().parent / "hyperparams"
EVAL_SEED_BASE = 1_000_000
METRIC_SEED_BASE = 2_000_000
DEV_SEED_BASE = 3_000_000
_CHECKPOINT_RE = re.compile(r"^rl_model_(\d+)_steps\.zip$")
RESIDUAL_FOLDER = "residual"
ORDERED_DICT_TAG = "tag:yaml.org,2002:python/object/apply:collections.OrderedDict"


# ---------------------------------------------------------------------------------------------- YAML
class ZooLoader(yaml.SafeLoader):
    """``yaml.SafeLoader`` that also reads rl-zoo3's ``config.yml`` / ``args.yml``.

    rl-zoo3 dumps them as ``collections.OrderedDict`` (``!!python/object/apply:collections.OrderedDict``, a list
    of ``[key, value]`` pairs), which ``yaml.safe_load`` refuses.  This loader accepts exactly that tag, in exactly
    that form, and builds a plain ``dict``; every other Python tag is refused as by ``SafeLoader``.
    """


def _construct_ordered_dict(loader: yaml.SafeLoader, node: yaml.Node) -> dict[Any, Any]:
    pairs_node = node.value[0] if isinstance(node, yaml.SequenceNode) and len(node.value) == 1 else None
    if not isinstance(pairs_node, yaml.SequenceNode):
        raise yaml.constructor.ConstructorError(None, None, "expected an OrderedDict as rl-zoo3 dumps it "
                                                "(one list of [key, value] pairs)", node.start_mark)
    out: dict[Any, Any] = {}
    for pair in pairs_node.value:
        if not (isinstance(pair, yaml.SequenceNode) and len(pair.value) == 2):
            raise yaml.constructor.ConstructorError(None, None, "an OrderedDict item must be a [key, value] pair",
                                                    pair.start_mark)
        key = loader.construct_object(pair.value[0], deep=True)
        value = loader.construct_object(pair.value[1], deep=True)
        try:
            out[key] = value
        except TypeError as exc:
            raise yaml.constructor.ConstructorError(None, None, f"unhashable OrderedDict key {key!r}",
                                                    pair.start_mark) from exc
    return out


ZooLoader.add_constructor(ORDERED_DICT_TAG, _construct_ordered_dict)


def yaml_mapping(text: str) -> dict[str, Any]:
    """An ``argparse`` type: a YAML mapping such as ``"{force_range: [2800, 3200]}"`` (environment arguments on
    the command line); anything else is refused with the value it got."""
    import argparse

    value = yaml.safe_load(text)
    if not isinstance(value, Mapping):
        raise argparse.ArgumentTypeError(f"expected a YAML mapping such as '{{failure_rate: 2.0}}', got {text!r}")
    return dict(value)


def read_yaml(path: str | os.PathLike[str]) -> Any:
    """A YAML file of ours or rl-zoo3's (hyperparameters, ``config.yml``, ``args.yml``), read by :class:`ZooLoader`."""
    with open(path) as fh:
        return yaml.load(fh, Loader=ZooLoader)  # a SafeLoader subclass: no arbitrary objects


def algo_class(algo: str) -> Any:
    """The SB3 / sb3-contrib class of ``algo``."""
    algo = algo.lower()
    if algo == "ppo":
        from stable_baselines3 import PPO

        return PPO
    if algo == "sac":
        from stable_baselines3 import SAC

        return SAC
    if algo == "td3":
        from stable_baselines3 import TD3

        return TD3
    if algo == "tqc":
        try:
            from sb3_contrib import TQC
        except ImportError as exc:  # pragma: no cover - depends on the install
            raise ImportError("algo 'tqc' needs sb3-contrib (pip install -e '.[rl]')") from exc
        return TQC
    if algo == "ppo_lstm":  # rl-zoo3's name for sb3-contrib's RecurrentPPO
        try:
            from sb3_contrib import RecurrentPPO
        except ImportError as exc:  # pragma: no cover - depends on the install
            raise ImportError("algo 'ppo_lstm' needs sb3-contrib (pip install -e '.[rl]')") from exc
        return RecurrentPPO
    raise ValueError(f"unknown algo {algo!r}; choose one of {', '.join(ALGO_NAMES)}")


def env_name(env_id: str) -> str:
    """rl-zoo3's file-system name of an id (``huggingface_sb3.EnvironmentName``): "/" -> "-"."""
    return env_id.replace("/", "-")


# ---------------------------------------------------------------------------------------------- hyperparameters
class LinearSchedule:
    """rl-zoo3's ``lin_<value>`` schedule: ``value * progress_remaining`` (picklable)."""

    def __init__(self, initial: float) -> None:
        self.initial = float(initial)

    def __call__(self, progress_remaining: float) -> float:
        return progress_remaining * self.initial

    def __repr__(self) -> str:
        return f"LinearSchedule({self.initial})"


def hyperparams_file(algo: str, path: str | os.PathLike[str] | None = None) -> Path:
    """``path`` or ``agents/hyperparams/<algo>.yml``."""
    return Path(path) if path is not None else HYPERPARAMS_DIR / f"{algo.lower()}.yml"


def read_hyperparams(algo: str, env_id: str, path: str | os.PathLike[str] | None = None,
                     overrides: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """The raw (YAML) hyperparameters of ``env_id`` in the rl-zoo3 file of ``algo`` (or ``path``).

    Like rl-zoo3, the key is the full id; a ``default`` entry is used when the id is absent.
    """
    f = hyperparams_file(algo, path)
    table = read_yaml(f)
    if not isinstance(table, dict):
        raise ValueError(f"{f}: expected a mapping from env ids to hyperparameters")
    if env_id in table:
        hp = dict(table[env_id])
    elif "default" in table:
        hp = dict(table["default"])
    else:
        raise ValueError(f"hyperparameters for {algo}-{env_id} not found in {f}")
    if overrides:
        hp.update(overrides)
    if "n_timesteps" not in hp:
        raise ValueError(f"{f}: {env_id} has no n_timesteps (required by rl-zoo3)")
    return hp


_UNSUPPORTED = ("env_wrapper", "monitor_kwargs")


def frame_stack_of(value: Any) -> int:
    """The number of stacked observations an rl-zoo3 ``frame_stack`` entry asks for (``None``/absent: 1, no
    stacking); ``ValueError`` naming the entry unless it is a whole number >= 1."""
    if value is None:
        return 1
    if (isinstance(value, bool) or not isinstance(value, int | float) or not np.isfinite(value)
            or int(value) != value or value < 1):
        raise ValueError(f"frame_stack must be a whole number of observations >= 1, got {value!r}")
    return int(value)


def eval_zoo_expr(expr: str) -> Any:
    """Evaluate an rl-zoo3 Python-expression string (``"dict(net_arch=[64, 64])"``) with ``nn`` in scope."""
    from torch import nn

    return eval(expr, {"__builtins__": {}, "dict": dict, "list": list, "tuple": tuple, "nn": nn,
                       "float": float, "int": int, "True": True, "False": False, "None": None})


def process_hyperparams(raw: Mapping[str, Any], n_actions: int) -> dict[str, Any]:
    """rl-zoo3's pre-processing of a hyperparameter entry, split into what our trainer needs.

    Returns ``{"model": kwargs of the algorithm, "n_envs", "n_timesteps", "normalize" (None or
    VecNormalize kwargs), "env_kwargs", "frame_stack", "vec_env_wrapper", "callback"}`` (the last two as written in
    the YAML, see :func:`wrap_vec_env` and :func:`make_callbacks`; ``frame_stack``: the number of observations
    the policy sees, 1 = no stacking).  Keys that rl-zoo3 supports but we do not (gym wrappers, monitor
    arguments) raise ``ValueError``.
    """
    hp = dict(raw)
    bad = [k for k in _UNSUPPORTED if k in hp]
    if bad:
        raise ValueError(f"hyperparameter keys {bad} are not supported by agents.train")
    out: dict[str, Any] = {"n_envs": int(hp.pop("n_envs", 1)), "n_timesteps": int(float(hp.pop("n_timesteps")))}
    for key in ("learning_rate", "clip_range", "clip_range_vf"):
        v = hp.get(key)
        if isinstance(v, str):
            kind, value = v.split("_")
            if kind != "lin":
                raise ValueError(f"{key}: unknown schedule {v!r} (rl-zoo3 knows 'lin_<value>')")
            hp[key] = LinearSchedule(float(value))
    if isinstance(hp.get("train_freq"), list):
        hp["train_freq"] = tuple(hp["train_freq"])
    out["frame_stack"] = frame_stack_of(hp.pop("frame_stack", None))
    out["vec_env_wrapper"] = hp.pop("vec_env_wrapper", None)
    out["callback"] = hp.pop("callback", None)
    norm = hp.pop("normalize", False)
    if isinstance(norm, str):
        norm = eval_zoo_expr(norm)
    if norm is True:
        norm = {}
    if isinstance(norm, dict):
        norm = dict(norm)
        if "gamma" in hp:  # rl-zoo3: the return normalisation uses the algorithm's discount
            norm["gamma"] = hp["gamma"]
    out["normalize"] = norm if isinstance(norm, dict) else None
    for key in ("policy_kwargs", "replay_buffer_kwargs"):
        if isinstance(hp.get(key), str):
            hp[key] = eval_zoo_expr(hp[key])
    env_kwargs = hp.pop("env_kwargs", None) or {}
    if isinstance(env_kwargs, str):
        env_kwargs = eval_zoo_expr(env_kwargs)
    out["env_kwargs"] = dict(env_kwargs)
    noise_type = hp.pop("noise_type", None)
    noise_std = hp.pop("noise_std", None)
    if noise_type is not None:
        from stable_baselines3.common.noise import NormalActionNoise, OrnsteinUhlenbeckActionNoise

        sigma = float(noise_std) * np.ones(n_actions)
        if "normal" in noise_type:
            hp["action_noise"] = NormalActionNoise(mean=np.zeros(n_actions), sigma=sigma)
        elif "ornstein-uhlenbeck" in noise_type:
            hp["action_noise"] = OrnsteinUhlenbeckActionNoise(mean=np.zeros(n_actions), sigma=sigma)
        else:
            raise ValueError(f"unknown noise_type {noise_type!r}")
    out["model"] = hp
    return out


# ---------------------------------------------------------------------------------------------- environments
def class_entries(spec: Any, key: str) -> list[tuple[str, dict[str, Any]]]:
    """``(class path, kwargs)`` of an rl-zoo3 class entry (``vec_env_wrapper``, ``callback``): a class path,
    ``{path: kwargs}``, or a list of these; ``key`` names the entry in errors."""
    if spec is None:
        return []
    out = []
    for item in spec if isinstance(spec, list) else [spec]:
        if isinstance(item, Mapping):
            if len(item) != 1:
                raise ValueError(f"{key}: one class per entry, got {item!r}")
            path, kwargs = next(iter(item.items()))
        else:
            path, kwargs = item, {}
        out.append((str(path), dict(kwargs or {})))
    return out


def _import_class(path: str, key: str) -> Any:
    import importlib

    module, _, name = path.rpartition(".")
    try:
        return getattr(importlib.import_module(module), name)
    except (ImportError, AttributeError, ValueError) as err:
        raise ValueError(f"{key}: cannot import {path!r} ({err})") from err


def wrap_vec_env(venv: Any, spec: Any) -> Any:
    """Apply an rl-zoo3 ``vec_env_wrapper`` entry: a class path, ``{path: kwargs}``, or a list of these."""
    for path, kwargs in class_entries(spec, "vec_env_wrapper"):
        venv = _import_class(path, "vec_env_wrapper")(venv, **kwargs)
    return venv


def make_callbacks(spec: Any) -> list[Any]:
    """The SB3 callbacks of an rl-zoo3 ``callback`` entry (as rl-zoo3's ``get_callback_list`` builds them)."""
    return [_import_class(path, "callback")(**kwargs) for path, kwargs in class_entries(spec, "callback")]


def wrapper_kwargs(spec: Any, class_path: str) -> dict[str, Any] | None:
    """The kwargs of ``class_path`` in an rl-zoo3 ``vec_env_wrapper`` entry (as :func:`wrap_vec_env` reads it);
    ``None`` where the entry does not name that class."""
    for item in spec if isinstance(spec, list) else [spec]:
        if isinstance(item, Mapping) and class_path in item:
            return dict(item[class_path] or {})
        if item == class_path:
            return {}
    return None


def make_train_env(env_id: str, n_envs: int, seed: int, env_kwargs: Mapping[str, Any] | None = None,
                   normalize: Mapping[str, Any] | None = None, monitor_file: str | None = None,
                   vecnormalize_path: str | os.PathLike[str] | None = None, training: bool = True,
                   vec_env_wrapper: Any = None, frame_stack: int = 1) -> Any:
    """Native batched vector env -> ``vec_env_wrapper`` (e.g. residual) -> ``VecMonitor`` -> ``VecNormalize``
    -> ``VecFrameStack`` (``frame_stack`` > 1).

    ``vecnormalize_path`` loads saved statistics (resume / evaluation); ``training=False``
    freezes them and switches reward normalisation off (evaluation environments).  As in rl-zoo3,
    the ``vec_env_wrapper`` sees the raw (unnormalised) environment and the frames are stacked after
    the normalisation (the statistics are those of one observation).
    """
    from stable_baselines3.common.vec_env import VecFrameStack, VecMonitor, VecNormalize

    import vsa_gym.envs  # noqa: F401  (registers the ids)
    from vsa_gym.envs.sb3 import make_sb3_vec_env

    venv: Any = make_sb3_vec_env(env_id, n_envs=n_envs, seed=seed, **dict(env_kwargs or {}))
    venv = wrap_vec_env(venv, vec_env_wrapper)
    venv = VecMonitor(venv, filename=monitor_file)
    if vecnormalize_path is not None:
        venv = VecNormalize.load(str(vecnormalize_path), venv)
    elif normalize is not None:
        venv = VecNormalize(venv, **dict(normalize))
    if isinstance(venv, VecNormalize) and not training:
        venv.training = False
        venv.norm_reward = False
    if frame_stack > 1:
        venv = VecFrameStack(venv, frame_stack)
    return venv


# ---------------------------------------------------------------------------------------------- run layout
def is_residual(vec_env_wrapper: Any) -> bool:
    """Whether a ``vec_env_wrapper`` hyperparameter makes a residual agent (a wrapper of :mod:`agents.residual`)."""
    from agents.residual import residual_config

    return vec_env_wrapper is not None and residual_config(vec_env_wrapper) is not None


def run_log_folder(log_folder: str | os.PathLike[str], vec_env_wrapper: Any = None, new_run: bool = False) -> Path:
    """The log folder of a run: ``LOG/residual`` for a residual agent (``LOG`` itself when it is already named
    ``residual``), ``LOG`` for a pure one.

    rl-zoo3 finds a run as ``FOLDER/ALGO/ENV_NAME_ID`` (``ALGO`` one of its algorithm names), so the log
    folder is the only part of the path that can tell residual from pure runs; ``rl_zoo3.enjoy -f LOG/residual``
    reads the residual ones.  ``new_run``: refuse to put a pure run into a folder named ``residual``.
    """
    log = Path(log_folder)
    if is_residual(vec_env_wrapper):
        return log if log.name == RESIDUAL_FOLDER else log / RESIDUAL_FOLDER
    if new_run and log.name == RESIDUAL_FOLDER:
        raise ValueError(f"{log}: a folder named {RESIDUAL_FOLDER!r} holds residual runs only; give its parent "
                         "as the log folder of a pure run")
    return log


def run_params_dir(model_path: str | os.PathLike[str], env_id: str) -> Path | None:
    """``SAVE_PATH/ENV_NAME`` (with ``config.yml``) of a model file of the layout; ``None`` outside a run."""
    p = Path(model_path)
    for cand in (p.parent / env_name(env_id), p.parent / p.stem):
        if (cand / "config.yml").exists():
            return cand
    return None


def run_config(params_dir: str | os.PathLike[str]) -> dict[str, Any]:
    """The hyperparameters of a run (``config.yml``, ours or rl-zoo3's)."""
    return dict(read_yaml(Path(params_dir) / "config.yml") or {})


def run_args(params_dir: str | os.PathLike[str]) -> dict[str, Any]:
    """The arguments of a run (``args.yml``, ours or rl-zoo3's; empty when absent)."""
    f = Path(params_dir) / "args.yml"
    return dict(read_yaml(f) or {}) if f.exists() else {}


def run_env_kwargs(params_dir: str | os.PathLike[str]) -> dict[str, Any]:
    """The environment arguments a run was trained with, resolved as ``rl_zoo3.enjoy`` does: ``env_kwargs`` of
    ``config.yml``, replaced by ``env_kwargs`` of ``args.yml`` (rl-zoo3's ``--env-kwargs``) when that is not null."""
    kw = run_config(params_dir).get("env_kwargs") or {}
    override = run_args(params_dir).get("env_kwargs")
    if override is not None:
        kw = override
    return dict(eval_zoo_expr(kw) if isinstance(kw, str) else kw)


def run_dirs(log_folder: str | os.PathLike[str], algo: str, env_id: str) -> list[Path]:
    """Existing run directories ``LOG/ALGO/ENV_NAME_<id>`` sorted by run id."""
    base = Path(log_folder) / algo
    pat = re.compile(rf"^{re.escape(env_name(env_id))}_(\d+)$")
    found = [(int(m.group(1)), p) for p in base.glob(f"{env_name(env_id)}_*") if (m := pat.match(p.name))]
    return [p for _, p in sorted(found)]


def new_run_dir(log_folder: str | os.PathLike[str], algo: str, env_id: str) -> Path:
    """Create and return the next run directory (rl-zoo3's ``get_latest_run_id + 1``).

    The directory is claimed with an exclusive ``mkdir``, so concurrent trials of a sweep that
    share the log folder never get the same one.
    """
    (Path(log_folder) / algo).mkdir(parents=True, exist_ok=True)
    while True:
        existing = run_dirs(log_folder, algo, env_id)
        last = int(existing[-1].name.rsplit("_", 1)[1]) if existing else 0
        d = Path(log_folder) / algo / f"{env_name(env_id)}_{last + 1}"
        try:
            d.mkdir()
            return d
        except FileExistsError:
            continue


def checkpoints(save_path: str | os.PathLike[str], off_policy: bool, normalized: bool) -> list[tuple[int, Path]]:
    """Complete checkpoints ``(timesteps, zip)`` in ``save_path``, oldest first.

    A checkpoint is complete when its model, and where used its VecNormalize statistics and
    replay buffer, are all there (a run killed while saving leaves an incomplete one, skipped).
    """
    out = []
    for p in Path(save_path).glob("rl_model_*_steps.zip"):
        m = _CHECKPOINT_RE.match(p.name)
        if not m:
            continue
        n = int(m.group(1))
        if normalized and not (p.parent / f"rl_model_vecnormalize_{n}_steps.pkl").exists():
            continue
        if off_policy and not (p.parent / f"rl_model_replay_buffer_{n}_steps.pkl").exists():
            continue
        out.append((n, p))
    return sorted(out)


def read_vecnormalize(path: str | os.PathLike[str]) -> Any:
    """Saved ``VecNormalize`` statistics without an environment attached (what ``VecNormalize.load`` unpickles
    before it attaches one): enough to normalise observations by hand or to read ``obs_rms`` / ``ret_rms``."""
    import pickle

    with open(path, "rb") as fh:
        return pickle.load(fh)


def vecnormalize_for(model_path: str | os.PathLike[str]) -> Path | None:
    """The VecNormalize statistics that belong to a model file of the layout (``None`` if there are none)."""
    p = Path(model_path)
    m = _CHECKPOINT_RE.match(p.name)
    if m:
        cand = p.parent / f"rl_model_vecnormalize_{m.group(1)}_steps.pkl"
    elif p.name == "best_model.zip":
        cand = p.parent / "best_model_vecnormalize.pkl"
    else:
        cand = p.parent / p.stem / "vecnormalize.pkl"
    return cand if cand.exists() else None


def is_recurrent(policy: Any) -> bool:
    """Whether an SB3 policy carries an LSTM state between steps (sb3-contrib's ``RecurrentActorCriticPolicy``,
    rl-zoo3's ``ppo_lstm``)."""
    return hasattr(policy, "lstm_actor")


def algo_of_model(model_path: str | os.PathLike[str]) -> str:
    """Which algorithm saved a model .zip: the run layout (``.../ALGO/ENV_ID/x.zip``), else the zip's contents."""
    p = Path(model_path)
    if p.parent.parent.name in ALGO_NAMES:
        return p.parent.parent.name
    with zipfile.ZipFile(p) as zf:
        data = json.loads(zf.read("data").decode())
    module = str(data.get("policy_class", {}).get("__module__", ""))
    if module.endswith("common.recurrent.policies"):  # sb3-contrib's RecurrentActorCriticPolicy
        return "ppo_lstm"
    for algo in ALGO_NAMES:
        if f".{algo}." in f".{module}.":
            return algo
    if module.endswith("common.policies") and "clip_range" in data:  # PPO's ActorCriticPolicy
        return "ppo"
    raise ValueError(f"cannot tell the algorithm of {model_path} (policy module {module!r}); pass --algo")


def read_json(path: str | os.PathLike[str], default: Any = None) -> Any:
    p = Path(path)
    return json.loads(p.read_text()) if p.exists() else default


def write_json(path: str | os.PathLike[str], obj: Any) -> None:
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    tmp = p.with_suffix(p.suffix + ".tmp")
    tmp.write_text(json.dumps(obj, indent=2, sort_keys=True, default=_json_default))
    os.replace(tmp, p)


def _json_default(o: Any) -> Any:
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, Path):
        return str(o)
    return repr(o)
