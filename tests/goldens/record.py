"""Golden outputs that a restructuring of the env layer, the device cores or identification must keep (issue 17).

Each group is a flat ``dict[str, np.ndarray]`` recorded by this module and stored in ``tests/goldens/<group>.npz``;
``tests/test_goldens.py`` recomputes every group and compares it with the stored copy to 1e-12 (relative to each
array's largest magnitude; ``identify`` to :data:`TOLERANCE` ``["identify"]`` = 1e-8, see there).  The groups cover
what users and the other modules see:

* ``tasks``: the batched tasks stepped through ``task.step`` (every task; voltage and current mode; sensor noise;
  domain randomisation; both integrators; the threaded ``parallel_rows`` path; failure and drive-off steps, reference
  and road renewals), with per-step observations, rewards, terminations and every ``info`` key, and the final state;
* ``envs``: ``gym.make`` single environments (every id, two seeds, both control modes, domain randomisation off/on)
  and ``gym.make_vec`` native vector environments with autoreset, through the registry's wrappers;
* ``baselines``: the papers' controllers on their tasks (``evaluate_policy``) and the eLPAS rig experiment;
* ``identify``: adapter replays of every candidate effect (drive, vsaUT-II, eLPAS, truth-simulator records) and the
  CLI's identification result (effects, parameters, metrics) on synthetic and truth records.

Re-record (only when a change is *meant* to alter results, and say so in the commit)::

    python -m tests.goldens.record --write [GROUP ...]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

HERE = Path(__file__).resolve().parent
Golden = dict[str, np.ndarray]


def _put(out: Golden, key: str, value: Any) -> None:
    arr = np.asarray(value)
    if arr.dtype == object:
        raise TypeError(f"golden {key}: not numeric")
    out[key] = arr.astype(np.float64) if arr.dtype.kind in "biuf" else arr


STRIDE = 5
"""Per-step values are kept at every ``STRIDE``-th step (the state carries any earlier difference forward) plus
their sum over all steps (a change at a skipped step still shows)."""


def _stack_steps(out: Golden, prefix: str, steps: list[dict[str, Any]]) -> None:
    for key in steps[0]:
        series = np.stack([np.asarray(s[key], dtype=np.float64) for s in steps])
        _put(out, f"{prefix}/{key}", series[::STRIDE])
        _put(out, f"{prefix}/{key}.sum", series.sum(axis=0))


# ----------------------------------------------------------------------------- tasks
def _task_cases() -> list[tuple[str, type, dict[str, Any], int, int]]:
    from vsa_gym.devices.elpas.env_force_tracking import ForceTrackingTask
    from vsa_gym.devices.elpas.env_quarter_car import QuarterCarTask
    from vsa_gym.devices.vsaut2.env_position_stiffness import PositionStiffnessTask
    from vsa_gym.devices.vsaut2.env_throw import ThrowTask

    return [
        ("ps_default", PositionStiffnessTask, {}, 3, 700),
        ("ps_current_noise", PositionStiffnessTask, {"control_mode": "current", "sensor_noise": True,
                                                     "control_dt": 1e-3}, 2, 700),
        ("ps_dr_etd", PositionStiffnessTask, {"domain_randomization": {"I_o": (0.005, 0.02)}, "integrator": "etd",
                                              "regen": "count", "episode_steps": 300}, 3, 700),
        ("ps_parallel", PositionStiffnessTask, {"control_dt": 1e-3, "parallel_rows": True}, 65, 60),
        ("ps_wide", PositionStiffnessTask, {"control_dt": 1e-3}, 65, 60),
        ("throw_stops", ThrowTask, {"energy_budget": 50.0, "release_angle": 1.2}, 3, 500),
        ("throw_budget", ThrowTask, {"energy_budget": 0.5}, 2, 300),
        ("throw_current_noise", ThrowTask, {"control_mode": "current", "sensor_noise": True}, 2, 500),
        ("ft_default", ForceTrackingTask, {}, 3, 900),
        ("ft_current_noise", ForceTrackingTask, {"control_mode": "current", "sensor_noise": True}, 3, 900),
        ("ft_dr_parallel", ForceTrackingTask, {"domain_randomization": {"friction.F_c": (0.15, 0.3)},
                                               "parallel_rows": True}, 70, 60),
        ("qc_default", QuarterCarTask, {"road_duration_s": 0.05}, 3, 120),
        ("qc_current_noise", QuarterCarTask, {"control_mode": "current", "sensor_noise": True, "control_dt": 1e-3,
                                              "road_duration_s": 0.03}, 2, 120),
        ("qc_parallel", QuarterCarTask, {"road_duration_s": 0.05, "parallel_rows": True}, 70, 40),
    ]


def _task_action(name: str, k: int, n: int, m: int, rng: np.random.Generator) -> np.ndarray:
    """The test drive of the compiled-step tests: smooth commands with noise, saturating phases."""
    if m == 1:
        amp = 0.1 if name.startswith("ft") else 1.0
        return np.clip(amp * (np.sin(0.02 * k + np.arange(n))[:, None] + 0.3 * rng.standard_normal((n, 1))),
                       -1.3, 1.3)
    a = np.clip(0.6 * (np.sin(0.03 * k + np.arange(n)[:, None] + np.array([0.0, 1.0]))
                       + 0.3 * rng.standard_normal((n, 2))), -1.5, 1.5)
    if k >= 400 and k % 150 < 80:  # saturating frame commands: end stops, I^2 t trips (failure steps)
        a[:, 1] = 1.3 * np.where(np.arange(n) % 2 == 0, 1.0, -1.0)
    return a


def record_tasks() -> Golden:
    out: Golden = {}
    for name, cls, kw, n, steps in _task_cases():
        task = cls(n, **kw)
        task.seed_rows(np.arange(n), [40 + i for i in range(n)])
        task.reset()
        rng = np.random.default_rng(3)
        m = len(task.action_names)
        _put(out, f"tasks/{name}/obs0", task.observation())
        rows: list[dict[str, Any]] = []
        for k in range(steps):
            obs, rew, term, info = task.step(_task_action(name, k, n, m, rng))
            row = {"obs": obs, "reward": rew, "terminated": term}
            row.update({f"info.{key}": v for key, v in info.items()})
            rows.append(row)
            done = np.flatnonzero(term)
            if done.size:
                task.reset(done)
                rows[-1]["obs_after_reset"] = task.observation()
            else:
                rows[-1]["obs_after_reset"] = obs
        _stack_steps(out, f"tasks/{name}", rows)
        for key, v in task.s.items():
            if key != "hist":
                _put(out, f"tasks/{name}/state.{key}", v)
    return out


# ----------------------------------------------------------------------------- gym.make / make_vec
DR = {
    "VsaUT2-PositionStiffness-v0": {"I_o": (0.005, 0.02)},
    "VsaUT2-Throw-v0": {"I_o": (0.005, 0.02)},
    "ELPAS-ForceTracking-v0": {"friction.F_c": (0.15, 0.3)},
    "ELPAS-QuarterCar-v0": {"friction.F_c": (0.15, 0.3)},
}


def record_envs() -> Golden:
    import gymnasium as gym

    from vsa_gym.envs import ENV_SPECS

    out: Golden = {}
    for name in ENV_SPECS:
        env_id = f"vsa_gym/{name}"
        for mode in ("voltage", "current"):
            for dr in (False, True):
                kw: dict[str, Any] = {"control_mode": mode}
                if dr:
                    kw["domain_randomization"] = DR[name]
                for seed in (0, 7):
                    env = gym.make(env_id, **kw)
                    rng = np.random.default_rng(seed)
                    obs, info = env.reset(seed=seed)
                    tag = f"envs/{name}/{mode}/dr{int(dr)}/s{seed}"
                    _put(out, f"{tag}/obs0", obs)
                    rows = []
                    for _ in range(150):
                        a = rng.uniform(-1.2, 1.2, size=env.action_space.shape)
                        obs, rew, term, trunc, info = env.step(a)
                        row = {"obs": obs, "reward": rew, "terminated": term, "truncated": trunc}
                        row.update({f"info.{k}": v for k, v in info.items()})
                        rows.append(row)
                        if term or trunc:
                            obs, _ = env.reset()
                    _stack_steps(out, tag, rows)
                    env.close()
        env = gym.make_vec(env_id, num_envs=3, vectorization_mode="vector_entry_point", max_episode_steps=40)
        rng = np.random.default_rng(11)
        obs, _ = env.reset(seed=[5, 6, 7])
        rows = []
        for _ in range(100):
            a = rng.uniform(-1.2, 1.2, size=env.action_space.shape)
            obs, rew, term, trunc, info = env.step(a)
            row = {"obs": obs, "reward": rew, "terminated": term, "truncated": trunc}
            row.update({f"info.{k}": v for k, v in info.items() if not k.startswith("_")
                        and np.asarray(v).dtype != object})
            rows.append(row)
        _stack_steps(out, f"envs/{name}/vector", rows)
        env.close()
    return out


# ----------------------------------------------------------------------------- baselines
def record_baselines() -> Golden:
    from baselines.elpas_cascade import ElpasCascade, elpas_cascade_factory
    from baselines.elpas_rig import run_rig
    from baselines.metrics import evaluate_policy
    from baselines.quarter_car import passive_factory, skyhook_factory
    from baselines.vsaut2_decoupled import vsaut2_decoupled_factory

    out: Golden = {}
    runs = [
        ("ps_decoupled", "vsa_gym/VsaUT2-PositionStiffness-v0", vsaut2_decoupled_factory(), 600),
        ("ft_cascade", "vsa_gym/ELPAS-ForceTracking-v0", elpas_cascade_factory(), 600),
        ("qc_passive", "vsa_gym/ELPAS-QuarterCar-v0", passive_factory(), 400),
        ("qc_skyhook", "vsa_gym/ELPAS-QuarterCar-v0", skyhook_factory(), 400),
    ]
    for name, env_id, factory, steps in runs:
        res = evaluate_policy(env_id, factory, seeds=[3, 4], episode_steps=steps)
        for key, v in sorted(res["per_episode"].items()):
            if np.asarray(v).dtype.kind in "biuf":
                _put(out, f"baselines/{name}/{key}", v)
    t = np.arange(801) * 1e-3
    f_ref = np.stack([2000.0 + 400.0 * np.sin(2 * np.pi * 3.0 * t), np.where(t > 0.2, 2600.0, 2000.0)])
    alpha = np.stack([0.05 * np.sin(2 * np.pi * 1.5 * t), np.zeros_like(t)])
    ctrl = ElpasCascade()
    rig = run_rig(ctrl, f_ref, alpha, gamma0=ctrl.lookup(f_ref[:, 0]))
    for key, v in sorted(rig.items()):
        _put(out, f"baselines/rig/{key}", v)
    return out


# ----------------------------------------------------------------------------- identification
def _theta_rows(ad: Any) -> tuple[dict[str, np.ndarray], int]:
    """Row 0 nominal, then one row per candidate effect with every parameter at ``absent + typical`` (clipped)."""
    names = list(ad.effects)
    n = len(names) + 1
    theta: dict[str, np.ndarray] = {}
    for j, name in enumerate(names):
        for p in ad.effects[name].params:
            col = theta.setdefault(f"{name}.{p.name}", np.full(n, p.absent))
            col[j + 1] = p.clip(p.absent + p.typical)
    for p in ad.base:
        theta.setdefault(f"base.{p.name}", np.full(n, p.clip(p.absent)))
    return theta, n


def _identify_records(tmp: Path) -> list[tuple[str, Path]]:
    from tests.truthsim.scenarios import draw_case, write_case
    from vsa_gym.devices.drive.synthetic import make_drive_record
    from vsa_gym.devices.elpas.synthetic import make_elpas_record
    from vsa_gym.devices.vsaut2.synthetic import make_vsaut2_record
    from vsa_gym.identify.record import write_record

    recs: list[tuple[str, Path]] = []
    for name, make in (("drive_coulomb", lambda: make_drive_record(4, "coulomb_friction")),
                       ("drive_backlash", lambda: make_drive_record(5, "backlash")),
                       ("elpas_random", lambda: make_elpas_record(2, "random")),
                       ):
        rec, _ = make()
        path = tmp / f"{name}.csv"
        write_record(path, rec.data, rec.meta)
        recs.append((name, path))
    path = tmp / "vsaut2_free.csv"
    make_vsaut2_record(3, "free_oscillation", "random", path=path)
    recs.append(("vsaut2_free", path))
    base = 20250 * 1000
    for name, seed, effects in (("truth_coulomb", base + 0, ("coulomb_friction",)),
                                ("truth_backlash", base + 11, ("backlash",)),
                                ("truth_nominal", base + 60, ())):
        recs.append((name, write_case(draw_case(seed, effects), tmp / name)))
    return recs


def record_identify() -> Golden:
    from vsa_gym.cli import main as cli
    from vsa_gym.identify.adapters import make_adapter
    from vsa_gym.identify.record import load_record

    out: Golden = {}
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        for name, path in _identify_records(tmp):
            rec = load_record(path)
            ad = make_adapter(rec)
            theta, n = _theta_rows(ad)
            y = ad.simulate(theta, n)
            _put(out, f"identify/{name}/replay", y[::20])  # every 20th sample, and the sums over all
            _put(out, f"identify/{name}/replay.sum", y.sum(axis=0))
            _put(out, f"identify/{name}/effects_order", np.arange(len(ad.effects)))
            js = tmp / f"{name}.json"
            if cli(["identify", str(path), "--json", str(js)]) != 0:
                raise RuntimeError(f"identify {name} failed")
            res = json.loads(js.read_text())
            named = [e["name"] for e in res["effects"]]
            _put(out, f"identify/{name}/named_hash", np.frombuffer(",".join(named).encode().ljust(64), np.uint8))
            for e in res["effects"]:
                for key, v in sorted(e["parameters"].items()):
                    _put(out, f"identify/{name}/effect.{e['name']}.{key}", float(v))
            for when in ("before", "after"):
                for sig, met in sorted(res["metrics"].get(when, {}).items()):
                    for key, v in sorted(met.items()):
                        if isinstance(v, int | float):
                            _put(out, f"identify/{name}/{when}.{sig}.{key}", float(v))
    return out


GROUPS: dict[str, Callable[[], Golden]] = {
    "tasks": record_tasks,
    "envs": record_envs,
    "baselines": record_baselines,
    "identify": record_identify,
}


#: comparison tolerance of a group relative to each array's largest magnitude (default 1e-12).  ``identify`` goes
#: through records drawn with numpy's vectorised transcendentals and through least squares on BLAS, whose last bits
#: can depend on the processor's vector extensions: on an AMD EPYC machine with AVX2 and no AVX-512 (2026-12-01) the
#: stored copy, recorded on another machine, differed by up to 5.5e-10 of its scale (a backlash contact frequency;
#: the replays of the truth records by up to 7e-12), identically with the code of 06ee146 and with the tuple-stepper
#: drive after it, which give the same bits on one machine.  1e-8 stays far below any change of a fitted effect that
#: a regression would make.
TOLERANCE: dict[str, float] = {"identify": 1e-8}


def path_of(group: str) -> Path:
    return HERE / f"{group}.npz"


def load(group: str) -> Golden:
    with np.load(path_of(group)) as z:
        return {k: z[k] for k in z.files}


def compare(got: Golden, want: Golden, tol: float = 1e-12) -> list[str]:
    """Differences between two goldens: missing or extra keys, shapes, and values beyond ``tol`` relative to the
    array's largest magnitude (at least 1)."""
    bad = [f"missing {k}" for k in sorted(set(want) - set(got))]
    bad += [f"unexpected {k}" for k in sorted(set(got) - set(want))]
    for k in sorted(set(want) & set(got)):
        a, b = got[k], want[k]
        if a.shape != b.shape:
            bad.append(f"{k}: shape {a.shape} != {b.shape}")
            continue
        if a.dtype.kind not in "f" or b.dtype.kind not in "f":
            if not np.array_equal(a, b):
                bad.append(f"{k}: differs")
            continue
        scale = max(1.0, float(np.nanmax(np.abs(b))) if b.size and np.isfinite(b).any() else 1.0)
        same_nan = np.array_equal(np.isnan(a), np.isnan(b))
        err = float(np.nanmax(np.abs(a - b))) if a.size and not np.isnan(a - b).all() else 0.0
        if not same_nan or err > tol * scale:
            nan = 'same' if same_nan else 'differs'
            bad.append(f"{k}: max |diff| {err:.3g} (scale {scale:.3g}, NaN pattern {nan})")
    return bad


def main(argv: list[str] | None = None) -> int:
    """Compare (default), ``--write`` the stored copies, or ``--save DIR`` / ``--against DIR`` a recording of another
    checkout: a change meant to keep results is checked bit for bit on one machine with ``--tol 0``, e.g. from a
    worktree of the commit before it, ``PYTHONPATH=. python /path/to/this/checkout/tests/goldens/record.py --save
    /tmp/g``, then here ``python -m tests.goldens.record --against /tmp/g --tol 0``."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("groups", nargs="*", default=list(GROUPS))
    ap.add_argument("--write", action="store_true", help="store the recorded goldens (default: compare)")
    ap.add_argument("--save", type=Path, metavar="DIR", help="write the recorded groups to DIR/<group>.npz instead")
    ap.add_argument("--against", type=Path, metavar="DIR", help="compare with DIR/<group>.npz (from --save)")
    ap.add_argument("--tol", type=float, default=None, help="tolerance for every group (default: TOLERANCE)")
    args = ap.parse_args(argv)
    status = 0
    for g in args.groups:
        got = GROUPS[g]()
        if args.write or args.save:
            where = path_of(g) if args.write else args.save / f"{g}.npz"
            where.parent.mkdir(parents=True, exist_ok=True)
            np.savez_compressed(where, **got)
            print(f"{g}: {len(got)} arrays -> {where}")
            continue
        if args.against:
            with np.load(args.against / f"{g}.npz") as z:
                want = {k: z[k] for k in z.files}
        else:
            want = load(g)
        bad = compare(got, want, TOLERANCE.get(g, 1e-12) if args.tol is None else args.tol)
        print(f"{g}: {len(got)} arrays, {len(bad)} differences")
        for line in bad[:40]:
            print("  " + line)
        status |= bool(bad)
    return status


if __name__ == "__main__":
    sys.exit(main())
