import numpy as np
import pytest

from vsa_gym.devices.vsaut2.model import VsaUT2Model


@pytest.fixture(scope="session")
def model() -> VsaUT2Model:
    return VsaUT2Model()


def input_program(kind: int, T: int, dt: float = 1e-3, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Varied, reproducible voltage/torque programmes: (u (T, 2), tau (T,))."""
    rng = np.random.default_rng(seed + kind)
    t = np.arange(T) * dt
    if kind == 0:  # steps on both motors
        u = np.stack([np.where(t < t[-1] / 2, 24.0, -24.0), np.where(t < t[-1] / 3, 3.0, -3.0)], 1)
        tau = np.zeros(T)
    elif kind == 1:  # sines plus a torque disturbance
        u = np.stack([10 * np.sin(2 * np.pi * 3 * t), 20 * np.sin(2 * np.pi * 5 * t)], 1)
        tau = 2.0 * np.sin(2 * np.pi * 2 * t)
    elif kind == 2:  # random piecewise-constant voltages held 10 ms
        held = rng.uniform(-24, 24, size=(T // 10 + 1, 2))
        u = np.repeat(held, 10, axis=0)[:T]
        tau = rng.normal(0, 0.5) * np.ones(T)
    elif kind == 3:  # chirp on the frame, full voltage on the pivot
        u = np.stack([np.full(T, -24.0), 24 * np.sin(2 * np.pi * (1 + 20 * t) * t)], 1)
        tau = np.full(T, -1.5)
    else:  # saturating commands (beyond the supply) and a torque step
        u = np.stack([np.full(T, 40.0), np.full(T, -40.0)], 1)
        tau = np.where(t > t[-1] / 2, 3.0, 0.0)
    return u, tau
