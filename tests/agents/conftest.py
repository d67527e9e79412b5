"""Tiny settings shared by the agent tests: short episodes, few environments, small batches."""

from __future__ import annotations

import pytest

EPISODE = 100  # steps per training episode in the tests (env kwarg max_episode_steps)

TINY = {
    "ppo": {"n_envs": 2, "n_steps": 128, "batch_size": 64, "n_epochs": 2},
    "sac": {"n_envs": 2, "learning_starts": 100, "batch_size": 64, "buffer_size": 10_000},
    "td3": {"n_envs": 2, "learning_starts": 100, "batch_size": 64, "buffer_size": 10_000},
    "tqc": {"n_envs": 2, "learning_starts": 100, "batch_size": 64, "buffer_size": 10_000},
    "ppo_lstm": {"n_envs": 2, "n_steps": 128, "batch_size": 64, "n_epochs": 2},
}


def tiny(algo: str, **extra: object) -> dict:
    return {**TINY[algo], "env_kwargs": {"max_episode_steps": EPISODE}, **extra}


@pytest.fixture(autouse=True)
def _one_torch_thread():
    import torch

    n = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(n)
