"""The fixed-step RK4 core against a stiff Radau reference (rtol 1e-9) on five varied trajectories."""

import numpy as np
import pytest

from vsa_gym.physics.integrate import reference_solution
from vsa_gym.vsaut2.model import N_STATES

from .conftest import input_program

T = 60  # control steps of 1 ms per trajectory (Radau at rtol 1e-9 is the slow part)
STARTS = [
    dict(q1=0.004, q2=0.0),
    dict(q1=0.012, q2=0.2, r=0.25),
    dict(q1=0.03, q2=-0.3, r=-0.2),
    dict(q1=0.045, q2=0.1, r=-0.3),
    dict(q1=0.006, q2=0.45, r=0.47),
]


@pytest.mark.parametrize("kind", range(5))
def test_rk4_matches_radau(model, kind):
    u, tau = input_program(kind, T)
    x0 = model.initial_state(1, **STARTS[kind])
    ref, e_ref = reference_solution(lambda k: (lambda y: model.rhs(y, u[k:k + 1], tau[k:k + 1])), x0[0], 1e-3, T)
    xs, es = model.simulate(x0, u[:, None, :], tau[:, None])
    xs, es = xs[:, 0], es[:, 0]
    # worst error of each state over the run, relative to that state's largest magnitude
    scale = np.maximum(np.abs(ref).max(axis=0), 1e-9)
    rel = (np.abs(xs - ref).max(axis=0) / scale)[:N_STATES]
    assert rel.max() <= 1e-3, f"worst relative state error {rel.max():.2e} (per state {np.array2string(rel)})"
    # energy channels, relative to the largest energy flow of the run
    e_err = np.abs(es - e_ref).max() / np.abs(e_ref).max()
    assert e_err <= 1e-3, f"energy channels differ by {e_err:.2e} of the largest flow"
