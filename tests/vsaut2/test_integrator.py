"""The fixed-step cores (RK4; the opt-in ETDRK4) against a stiff Radau reference (rtol 1e-9) on five trajectories."""

import numpy as np
import pytest

from vsa_gym.devices.vsaut2.model import N_STATES, VsaUT2Model
from vsa_gym.physics.integrate import reference_solution

from .conftest import input_program

T = 60  # control steps of 1 ms per trajectory (Radau at rtol 1e-9 is the slow part)
STARTS = [
    dict(q1=0.004, q2=0.0),
    dict(q1=0.012, q2=0.2, r=0.25),
    dict(q1=0.03, q2=-0.3, r=-0.2),
    dict(q1=0.045, q2=0.1, r=-0.3),
    dict(q1=0.006, q2=0.45, r=0.47),
]


_REFS: dict[int, tuple[np.ndarray, np.ndarray]] = {}


def _reference(model: VsaUT2Model, kind: int) -> tuple[np.ndarray, np.ndarray]:
    """Radau through input programme ``kind`` (computed once per session, shared by both integrators)."""
    if kind not in _REFS:
        u, tau = input_program(kind, T)
        x0 = model.initial_state(1, **STARTS[kind])
        _REFS[kind] = reference_solution(lambda k: (lambda y: model.rhs(y, u[k:k + 1], tau[k:k + 1])), x0[0],
                                         1e-3, T)
    return _REFS[kind]


@pytest.mark.parametrize("integrator", ["rk4", "etd"])
@pytest.mark.parametrize("kind", range(5))
def test_core_matches_radau(model, kind, integrator):
    u, tau = input_program(kind, T)
    x0 = model.initial_state(1, **STARTS[kind])
    ref, e_ref = _reference(model, kind)
    xs, es = VsaUT2Model(model.params, integrator=integrator).simulate(x0, u[:, None, :], tau[:, None])
    xs, es = xs[:, 0], es[:, 0]
    # worst error of each state over the run, relative to that state's largest magnitude
    scale = np.maximum(np.abs(ref).max(axis=0), 1e-9)
    rel = (np.abs(xs - ref).max(axis=0) / scale)[:N_STATES]
    assert rel.max() <= 1e-3, f"worst relative state error {rel.max():.2e} (per state {np.array2string(rel)})"
    # energy channels, relative to the largest energy flow of the run
    e_err = np.abs(es - e_ref).max() / np.abs(e_ref).max()
    assert e_err <= 1e-3, f"energy channels differ by {e_err:.2e} of the largest flow"


def test_etd_compiled_equals_numpy_path(model):
    """The compiled per-row ETDRK4 and the numpy ``exponential_rk4`` over the same RHS agree to round-off."""
    u, tau = input_program(2, 20)
    x0 = model.initial_state(3, q1=np.array([0.004, 0.02, 0.04]), q2=np.array([0.0, 0.2, -0.3]))
    uu = np.repeat(u[:, None, :], 3, axis=1) * np.array([1.0, -0.5, 0.8])[None, :, None]
    tt = np.repeat(tau[:, None], 3, axis=1)
    xc, ec = VsaUT2Model(model.params, integrator="etd").simulate(x0, uu, tt)
    xn, en = VsaUT2Model(model.params, integrator="etd", compiled=False).simulate(x0, uu, tt)
    scale = np.maximum(np.abs(xn).max(axis=(0, 1)), 1e-9)
    assert (np.abs(xc - xn).max(axis=(0, 1)) / scale).max() <= 1e-12
    assert np.abs(ec - en).max() <= 1e-12 * np.abs(en).max()
