"""Shared helper of the compiled-step tests (``tests/elpas/test_env_compiled_step.py``,
``tests/envs/test_vsaut2_compiled_step.py``)."""

from __future__ import annotations

from typing import Any

import numpy as np

from vsa_gym.envs.task import BatchedTask


def twin_tasks(cls: type, kw: dict[str, Any], n: int) -> tuple[BatchedTask, BatchedTask]:
    """Two identically seeded and reset ``cls(n, **kw)`` tasks: one to step through the compiled step, one
    through the numpy-level ``BatchedTask.step``."""
    tasks = []
    for _ in range(2):
        task = cls(n, **kw)
        task.seed_rows(np.arange(n), [40 + i for i in range(n)])
        task.reset()
        tasks.append(task)
    return tasks[0], tasks[1]
