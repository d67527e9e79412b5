"""The vsaUT-II environments' compiled task step equals their numpy-level step (``_advance``) row by row.

``PositionStiffnessTask.step`` / ``ThrowTask.step`` run the drive (the core's own compiled RK4/ETD step), sensing,
energy, margins, failures, reward terms and the observation of every row in one compiled call; the generic
``BatchedTask.step`` runs the tasks' numpy ``_advance``.  Both must give the same observations, rewards,
terminations, info and state, including steps where a reference or disturbance segment is renewed, in current
mode, with sensor noise (the random draws must come in the same order) and on failure steps.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from tests.compiled_step import twin_tasks
from vsa_gym.envs.task import BatchedTask
from vsa_gym.envs.vsaut2_position_stiffness import PositionStiffnessTask
from vsa_gym.envs.vsaut2_throw import ThrowTask

CASES = [
    (PositionStiffnessTask, {}, 3),
    (PositionStiffnessTask, {"control_mode": "current", "sensor_noise": True, "control_dt": 1e-3}, 2),
    (PositionStiffnessTask, {"domain_randomization": {"I_o": (0.005, 0.02)}, "integrator": "etd",
                             "regen": "count", "episode_steps": 300}, 3),
    (PositionStiffnessTask, {"control_dt": 1e-3}, 65),  # the core's parallel kernel
    (ThrowTask, {"energy_budget": 50.0, "release_angle": 1.2}, 3),  # frame and deflection stops before release
    (ThrowTask, {"energy_budget": 0.5}, 2),  # drives switched off once the budget is spent
    (ThrowTask, {"control_mode": "current", "sensor_noise": True}, 2),
]


@pytest.mark.parametrize(("cls", "kw", "n"), CASES)
def test_compiled_step_equals_numpy_step(cls: type, kw: dict[str, Any], n: int) -> None:
    fast, slow = twin_tasks(cls, kw, n)
    assert fast._use_kernel()
    rng = np.random.default_rng(3)
    steps = 900 if n < 10 else 120
    renewed, failed, clipped = False, False, False
    for k in range(steps):
        a = np.clip(0.6 * (np.sin(0.03 * k + np.arange(n)[:, None] + np.array([0.0, 1.0]))
                           + 0.3 * rng.standard_normal((n, 2))), -1.5, 1.5)
        if k >= 600 and k % 150 < 80:  # saturating frame commands: end stops, I^2 t trips (failure steps)
            a[:, 1] = 1.3 * np.where(np.arange(n) % 2 == 0, 1.0, -1.0)
        o1, r1, t1, i1 = fast.step(a)
        o2, r2, t2, i2 = BatchedTask.step(slow, a)
        np.testing.assert_allclose(o1, o2, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(r1, r2, rtol=1e-12, atol=1e-12)
        np.testing.assert_array_equal(t1, t2)
        assert list(i1) == list(i2)
        for key in i1:
            assert i1[key].dtype == i2[key].dtype, key
            np.testing.assert_allclose(i1[key], i2[key], rtol=1e-12, atol=1e-12, err_msg=key)
        np.testing.assert_array_equal(fast.s["meas"], fast._measure(fast._all_rows))  # the encoders' quantisers
        if cls is PositionStiffnessTask:
            renewed |= bool(np.any(fast.s["seg"][:, 1::7] > 0))  # some segment started after t = 0
        failed |= bool(np.any(i1["reward_failure"] != 0)) or bool(np.any(~i1.get("drive_enabled", True)))
        clipped |= bool(np.any(i1["action_clipped"]))
        done = np.flatnonzero(t1)
        if done.size:
            fast.reset(done)
            slow.reset(done)
        for key in fast.s:
            np.testing.assert_allclose(fast.s[key], slow.s[key], rtol=1e-12, atol=1e-12, err_msg=key)
    assert clipped
    if n < 10:
        assert renewed or cls is not PositionStiffnessTask, "the run must renew a segment for the check to cover it"
        assert failed, "the run must include failure (or drive-off) steps for the check to cover them"


@pytest.mark.parametrize("cls", [PositionStiffnessTask, ThrowTask])
def test_single_row_info_equals_the_batched_step(cls: type) -> None:
    fast, slow = twin_tasks(cls, {}, 1)
    for k in range(40):
        a = np.array([[np.sin(0.1 * k), 1.3 * np.cos(0.05 * k)]], dtype=np.float32)
        o1, r1, t1, i1 = fast.step_single(a)
        o2, r2, t2, i2 = BatchedTask.step_single(slow, a)
        np.testing.assert_array_equal(o1, o2)
        assert r1 == r2 and t1 == t2
        assert list(i1) == list(i2)
        for key in i1:
            assert type(i1[key]) is type(i2[key]) and i1[key] == i2[key], key


def test_non_finite_action_changes_nothing_in_the_compiled_step() -> None:
    task = PositionStiffnessTask(2)
    task.seed_rows(np.arange(2), [1, 2])
    task.reset()
    before = {k: v.copy() for k, v in task.s.items()}
    with pytest.raises(ValueError, match="must be finite"):
        task.step(np.array([[0.5, 0.1], [np.nan, 0.0]]))
    for k, v in task.s.items():
        np.testing.assert_array_equal(v, before[k])


def test_parallel_rows_runs_the_threaded_numpy_step_with_the_same_results() -> None:
    fast, _ = twin_tasks(PositionStiffnessTask, {}, 64)
    threaded = PositionStiffnessTask(64, parallel_rows=True)
    threaded.seed_rows(np.arange(64), [40 + i for i in range(64)])
    threaded.reset()
    assert fast._use_kernel() and not threaded._use_kernel()
    assert not PositionStiffnessTask(3, parallel_rows=True)._parallel  # below PARALLEL_MIN_ROWS: compiled step
    for k in range(5):
        a = np.full((64, 2), 0.3 * np.sin(0.5 * k))
        o1, r1, _, _ = fast.step(a)
        o2, r2, _, _ = threaded.step(a)
        np.testing.assert_allclose(o1, o2, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(r1, r2, rtol=1e-12, atol=1e-12)
