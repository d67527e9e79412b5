"""The eLPAS environments' compiled task step equals their numpy-level step (``_advance``) row by row.

``ForceTrackingTask.step`` / ``QuarterCarTask.step`` run the drive, reward terms, margins, failures and the
observation of every row in one compiled call (``parallel_rows`` and ``n >= 64``: the row loop on all cores);
the generic ``BatchedTask.step`` runs the tasks' numpy ``_advance``.  Both must give the same observations, rewards,
terminations and info, including steps where a reference segment or a road stretch is renewed and with
sensor noise (the random draws must come in the same order).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from tests.compiled_step import twin_tasks
from vsa_gym.envs.elpas_force_tracking import ForceTrackingTask
from vsa_gym.envs.elpas_quarter_car import QuarterCarTask
from vsa_gym.envs.task import BatchedTask

CASES = [
    (ForceTrackingTask, {}, 3),
    (ForceTrackingTask, {"control_mode": "current", "sensor_noise": True}, 3),
    (ForceTrackingTask, {"domain_randomization": {"friction.F_c": (0.15, 0.3)}, "parallel_rows": True}, 70),
    (QuarterCarTask, {"road_duration_s": 0.05}, 3),  # a new road stretch every 25 steps
    (QuarterCarTask, {"control_mode": "current", "sensor_noise": True, "control_dt": 1e-3,
                      "road_duration_s": 0.03}, 2),
    (QuarterCarTask, {"road_duration_s": 0.05, "parallel_rows": True}, 70),
]


@pytest.mark.parametrize(("cls", "kw", "n"), CASES)
def test_compiled_step_equals_numpy_step(cls: type, kw: dict[str, Any], n: int) -> None:
    fast, slow = twin_tasks(cls, kw, n)
    rng = np.random.default_rng(3)
    steps, amp = (1600, 0.1) if cls is ForceTrackingTask else (80, 1.0)  # force reference segments: 0.3-1.5 s
    renewed = False
    for k in range(steps):
        a = np.clip(amp * (np.sin(0.02 * k + np.arange(n))[:, None] + 0.3 * rng.standard_normal((n, 1))), -1.3, 1.3)
        if k % 97 == 0:
            a[0] = 1.2  # clipped
        o1, r1, t1, i1 = fast.step(a)
        o2, r2, t2, i2 = BatchedTask.step(slow, a)
        np.testing.assert_allclose(o1, o2, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(r1, r2, rtol=1e-12, atol=1e-12)
        np.testing.assert_array_equal(t1, t2)
        assert list(i1) == list(i2)
        for key in i1:
            np.testing.assert_allclose(i1[key], i2[key], rtol=1e-12, atol=1e-12, err_msg=key)
        np.testing.assert_array_equal(fast.s["meas"], fast._measure(fast._all_rows))  # the encoders' quantisers
        if cls is ForceTrackingTask:
            renewed |= bool(np.any(fast.s["fref_t0"] > 0))
        else:
            renewed |= bool(np.any(fast.s["road_k"] < k + 1))
        done = np.flatnonzero(t1)
        if done.size:
            fast.reset(done)
            slow.reset(done)
    assert renewed, "the run must renew a reference segment / road stretch for the check to cover it"
    for key in fast.s:
        np.testing.assert_allclose(fast.s[key], slow.s[key], rtol=1e-12, atol=1e-12, err_msg=key)


def test_non_finite_action_changes_nothing_in_the_compiled_step() -> None:
    task = ForceTrackingTask(2)
    task.seed_rows(np.arange(2), [1, 2])
    task.reset()
    before = {k: v.copy() for k, v in task.s.items()}
    with pytest.raises(ValueError, match="must be finite"):
        task.step(np.array([[0.5], [np.nan]]))
    for k, v in task.s.items():
        np.testing.assert_array_equal(v, before[k])
