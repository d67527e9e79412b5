"""Properties of the tasks' one step implementation (compiled row functions, issue 17).

Every task's step is written once, as compiled row functions; the golden outputs (tests/test_goldens.py) pin its
numbers.  These tests check what the goldens cannot: the same functions run as plain Python
(``NUMBA_DISABLE_JIT=1``) give the same numbers; the threaded ``parallel_rows`` step equals the serial one; the
single-row fast path equals the batched step; the sensors' quantisers hold; a non-finite action changes nothing;
the runs cover reference renewals, clipping and failure steps.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from typing import Any

import numpy as np
import pytest

from vsa_gym.devices.elpas.env_force_tracking import ForceTrackingTask
from vsa_gym.devices.elpas.env_quarter_car import QuarterCarTask
from vsa_gym.devices.vsaut2.env_position_stiffness import PositionStiffnessTask
from vsa_gym.devices.vsaut2.env_throw import ThrowTask

TASKS = {"PositionStiffnessTask": PositionStiffnessTask, "ThrowTask": ThrowTask,
         "ForceTrackingTask": ForceTrackingTask, "QuarterCarTask": QuarterCarTask}


def _task(cls: type, kw: dict[str, Any], n: int) -> Any:
    task = cls(n, **kw)
    task.seed_rows(np.arange(n), [40 + i for i in range(n)])
    task.reset()
    return task


def _actions(k: int, n: int, m: int, rng: np.random.Generator) -> np.ndarray:
    a = np.clip(0.6 * (np.sin(0.03 * k + np.arange(n)[:, None] + np.arange(m)) + 0.3 * rng.standard_normal((n, m))),
                -1.5, 1.5)
    if m == 2 and k >= 600 and k % 150 < 80:  # saturating frame commands: end stops, I^2 t trips
        a[:, 1] = 1.3 * np.where(np.arange(n) % 2 == 0, 1.0, -1.0)
    if k % 97 == 0:
        a[0] = 1.2  # clipped
    return a


def rollout(name: str, kw: dict[str, Any], n: int, steps: int) -> dict[str, list]:
    """Observations, rewards, terminations and info of a seeded run (resetting ended rows), as lists."""
    task = _task(TASKS[name], kw, n)
    rng = np.random.default_rng(3)
    out: dict[str, list] = {"obs": [], "reward": [], "terminated": []}
    for k in range(steps):
        obs, rew, term, info = task.step(_actions(k, n, len(task.action_names), rng))
        out["obs"].append(obs.tolist())
        out["reward"].append(rew.tolist())
        out["terminated"].append(term.tolist())
        for key, v in info.items():
            out.setdefault(f"info.{key}", []).append(np.asarray(v, dtype=np.float64).tolist())
        done = np.flatnonzero(term)
        if done.size:
            task.reset(done)
    out["x"] = task.s["x"].tolist()
    return out


PLAIN_CASES = [
    ("PositionStiffnessTask", {"control_mode": "current", "sensor_noise": True}, 2, 30),
    ("ThrowTask", {"integrator": "etd"}, 2, 30),
    ("ForceTrackingTask", {"control_mode": "current"}, 2, 30),
    ("QuarterCarTask", {"road_duration_s": 0.02}, 2, 30),
]


def test_the_step_functions_run_as_plain_python_with_the_same_numbers() -> None:
    """``NUMBA_DISABLE_JIT=1``: the same row functions, interpreted, in a fresh process."""
    code = ("import json, sys; from tests.envs.test_task_step import rollout, PLAIN_CASES; "
            "json.dump([rollout(*c) for c in PLAIN_CASES], sys.stdout)")
    env = dict(os.environ, NUMBA_DISABLE_JIT="1")
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True,
                         cwd=os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))
    plain = json.loads(res.stdout)
    for case, got in zip(PLAIN_CASES, plain, strict=True):
        want = rollout(*case)
        assert list(got) == list(want), case[0]
        for key in want:
            np.testing.assert_allclose(np.asarray(got[key], dtype=float), np.asarray(want[key], dtype=float),
                                       rtol=1e-12, atol=1e-12, err_msg=f"{case[0]} {key}")


@pytest.mark.parametrize(("cls", "kw"), [
    (PositionStiffnessTask, {"control_dt": 1e-3}),
    (ThrowTask, {"control_mode": "current"}),
    (ForceTrackingTask, {"domain_randomization": {"friction.F_c": (0.15, 0.3)}}),
    (QuarterCarTask, {"road_duration_s": 0.05}),
])
def test_parallel_rows_step_equals_the_serial_step(cls: type, kw: dict[str, Any]) -> None:
    serial, threaded = _task(cls, kw, 64), _task(cls, {**kw, "parallel_rows": True}, 64)
    assert threaded._parallel and not serial._parallel
    assert not cls(3, parallel_rows=True)._parallel  # below PARALLEL_MIN_ROWS: the serial step
    rng = np.random.default_rng(5)
    for k in range(25):
        a = _actions(k, 64, len(serial.action_names), rng)
        o1, r1, t1, i1 = serial.step(a)
        o2, r2, t2, i2 = threaded.step(a)
        np.testing.assert_array_equal(o1, o2)
        np.testing.assert_array_equal(r1, r2)
        np.testing.assert_array_equal(t1, t2)
        for key in i1:
            np.testing.assert_array_equal(i1[key], i2[key], err_msg=key)


@pytest.mark.parametrize("cls", list(TASKS.values()))
def test_single_row_info_equals_the_batched_step(cls: type) -> None:
    fast, batched = _task(cls, {}, 1), _task(cls, {}, 1)
    m = len(fast.action_names)
    for k in range(40):
        a = np.array([[np.sin(0.1 * k), 1.3 * np.cos(0.05 * k)][:m]], dtype=np.float32)
        o1, r1, t1, i1 = fast.step_single(a)
        o2, r2, t2, i2 = batched.step(a)
        np.testing.assert_array_equal(o1, o2[0])
        assert r1 == r2[0] and t1 == t2[0]
        assert list(i1) == list(i2)
        for key in i1:
            assert i1[key] == i2[key][0], key


@pytest.mark.parametrize(("cls", "kw", "n"), [
    (PositionStiffnessTask, {}, 3),
    (PositionStiffnessTask, {"control_mode": "current", "sensor_noise": True, "control_dt": 1e-3}, 2),
    (ThrowTask, {"energy_budget": 50.0, "release_angle": 1.2}, 3),
    (ThrowTask, {"energy_budget": 0.5}, 2),
    (ForceTrackingTask, {"control_mode": "current", "sensor_noise": True}, 3),
    (QuarterCarTask, {"road_duration_s": 0.05}, 3),
])
def test_runs_cover_renewals_clipping_failures_and_keep_the_encoders_quantised(cls: type, kw: dict[str, Any],
                                                                              n: int) -> None:
    task = _task(cls, kw, n)
    rng = np.random.default_rng(3)
    renewed = clipped = failed = False
    steps = 900 if cls in (PositionStiffnessTask, ThrowTask) else (1600 if cls is ForceTrackingTask else 80)
    for k in range(steps):
        _, _, term, info = task.step(_actions(k, n, len(task.action_names), rng))
        np.testing.assert_array_equal(task.s["meas"], task._measure(task._all_rows))  # the encoders' quantisers
        clipped |= bool(np.any(info["action_clipped"]))
        failed |= bool(np.any(info["reward_failure"] != 0)) or bool(np.any(~info.get("drive_enabled", True)))
        if cls is PositionStiffnessTask:
            renewed |= bool(np.any(task.s["seg"][:, 1::7] > 0))  # some segment started after t = 0
        elif cls is ForceTrackingTask:
            renewed |= bool(np.any(task.s["fref_t0"] > 0))
        elif cls is QuarterCarTask:
            renewed |= bool(np.any(task.s["road_k"] < k + 1))
        done = np.flatnonzero(term)
        if done.size:
            task.reset(done)
    assert clipped
    if cls in (PositionStiffnessTask, ThrowTask):
        assert failed, "the run must include failure (or drive-off) steps"
    else:
        assert renewed, "the run must renew a reference segment / road stretch"
    if cls is PositionStiffnessTask:
        assert renewed


@pytest.mark.parametrize(("cls", "bad"), [(PositionStiffnessTask, [[0.5, 0.1], [np.nan, 0.0]]),
                                          (ForceTrackingTask, [[0.5], [np.nan]])])
def test_non_finite_action_changes_nothing(cls: type, bad: list) -> None:
    task = _task(cls, {}, 2)
    before = {k: v.copy() for k, v in task.s.items()}
    with pytest.raises(ValueError, match="must be finite"):
        task.step(np.array(bad))
    for k, v in task.s.items():
        np.testing.assert_array_equal(v, before[k])
