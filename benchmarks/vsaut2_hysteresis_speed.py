"""Cost of the vsaUT-II's spring hysteresis (Dahl) on its two routes: the compiled core's state column and a numpy
:class:`~vsa_gym.devices.vsaut2.layout.Extension` of the same law (the route the model offered before).

Run::

    python -m benchmarks.vsaut2_hysteresis_speed [--rows 8] [--rounds 3]

Prints the CPU time of one 1 ms ``VsaUT2Model.step`` (10 RK4 sub-steps) of ``--rows`` rows for the nominal
compiled core, the compiled core with ``effects.M_h > 0`` (11 state columns), and the nominal core plus the numpy
extension; the best of ``--rounds`` rounds (CPU time of this process: less sensitive to other load).
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from typing import Any

import numpy as np

from vsa_gym.devices.vsaut2.model import ExtensionOutput, Kinematics, VsaUT2Model
from vsa_gym.devices.vsaut2.params import VsaUT2Effects, VsaUT2Params


@dataclasses.dataclass(frozen=True)
class NumpyDahl:
    """``dh/dt = (M_h phi_dot - |phi_dot| h) / phi_h``, torque ``-h`` at the ``lever_torque`` port (numpy path)."""

    M_h: float
    phi_h: float
    name: str = "numpy_dahl"
    n_states: int = 1

    def initial_state(self, n: int) -> np.ndarray:
        return np.zeros((n, 1))

    def evaluate(self, params: Any, kin: Kinematics, z: np.ndarray) -> ExtensionOutput:
        h, w = z[:, 0], kin.phi_dot
        return ExtensionOutput({"lever_torque": -h}, ((self.M_h * w - np.abs(w) * h) / self.phi_h)[:, None],
                               np.abs(w) * h * h / self.M_h)

    def stored_energy(self, params: Any, kin: Kinematics, z: np.ndarray) -> np.ndarray:
        return 0.5 * z[:, 0] ** 2 * self.phi_h / self.M_h


def step_cpu_s(model: VsaUT2Model, n: int, reps: int, rounds: int) -> float:
    """Best CPU seconds per 1 ms step of ``n`` rows over ``rounds`` rounds of ``reps`` steps."""
    x = model.initial_state(n, q1=0.01, r=0.2)
    u, tau = np.full((n, 2), 3.0), np.zeros(n)
    model.step(x, u, tau, 1e-3)  # compile / load the cache
    best = np.inf
    for _ in range(rounds):
        c0 = time.process_time()
        for _ in range(reps):
            model.step(x, u, tau, 1e-3)
        best = min(best, (time.process_time() - c0) / reps)
    return best


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rows", type=int, default=8)
    ap.add_argument("--rounds", type=int, default=3)
    args = ap.parse_args(argv)
    hyst = VsaUT2Params(effects=VsaUT2Effects(M_h=0.03, phi_h=0.02))
    cases = (("compiled, nominal (10 columns)", VsaUT2Model(), 2000),
             ("compiled, hysteresis column (11 columns)", VsaUT2Model(hyst), 2000),
             ("numpy Extension route", VsaUT2Model(VsaUT2Params(), (NumpyDahl(0.03, 0.02),)), 20))
    for name, model, reps in cases:
        t = step_cpu_s(model, args.rows, reps, args.rounds)
        print(f"{name}: {1e6 * t:.1f} us CPU per 1 ms step of {args.rows} rows")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
