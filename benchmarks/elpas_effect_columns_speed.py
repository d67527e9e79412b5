"""Cost of the eLPAS arm hysteresis (Dahl) on its two routes: the compiled core's state column and a numpy
:class:`~vsa_gym.devices.elpas.extensions.Extension` of the same law (the route the model offered before issue 17,
through the numpy path of the core's scheme).

Run::

    python -m benchmarks.elpas_effect_columns_speed [--rows 1 256] [--rounds 3]

Prints the CPU time of one 1 ms ``model.step_rig`` (4 ETDRK4 substeps, random voltage, alpha sine) of each
``--rows`` count for the nominal compiled core, the compiled core with ``effects.M_h > 0`` (the hysteresis
column), the compiled core with ``M_h = 0`` in every row but one (the column carried, the effect off in those rows)
and the numpy extension route; then ``ELPAS-ForceTracking-v0`` ``env.step`` nominal and with ``M_h > 0``.  Best of
``--rounds`` rounds (CPU time of this process: less sensitive to other load).  The speed of the core before against
after the move onto the generic stepper: ``python -m benchmarks.elpas_core_speed --against OLD_CHECKOUT``.
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from collections.abc import Callable

import numpy as np

from vsa_gym.devices.elpas import model as em
from vsa_gym.devices.elpas.extensions import ExtensionContext, ExtensionOutput
from vsa_gym.devices.elpas.params import ElpasEffects, ElpasParams

M_H, PHI_H = 20.0, 0.01  # N m, rad (sigma = 2000 N m/rad)


@dataclasses.dataclass(frozen=True)
class NumpyDahl:
    """``dh/dt = (M_h omega - |omega| h) / phi_h``, moment ``-h`` on the arm (numpy extension route)."""

    M_h: float
    phi_h: float
    name: str = "numpy_dahl"
    n_states: int = 1

    def initial_state(self, n: int) -> np.ndarray:
        return np.zeros((n, 1))

    def evaluate(self, ctx: ExtensionContext, s: np.ndarray) -> ExtensionOutput:
        h, w = s[:, 0], ctx.omega
        return ExtensionOutput(-h, np.zeros_like(h), ((self.M_h * w - np.abs(w) * h) / self.phi_h)[:, None])


def cpu_best(fn: Callable[[], None], reps: int, rounds: int) -> float:
    """Best CPU seconds per call over ``rounds`` rounds of ``reps`` calls (after one warm-up call)."""
    fn()
    best = np.inf
    for _ in range(rounds):
        c0 = time.process_time()
        for _ in range(reps):
            fn()
        best = min(best, (time.process_time() - c0) / reps)
    return best


def rig_case(p: ElpasParams, n: int, ext: tuple, reps: int, rounds: int) -> float:
    """CPU seconds per 1 ms ``step_rig`` of ``n`` rows."""
    rng = np.random.default_rng(0)
    volts = rng.uniform(-42.0, 42.0, (reps, n))
    alpha = np.radians(8.0) * np.sin(np.linspace(0.0, 6.0, reps))
    state = {"x": em.initial_state_rig(p, n, gamma=0.3, extensions=ext), "k": 0}

    def step() -> None:
        k = state["k"] % reps
        inp = np.stack([volts[k], np.full(n, alpha[k])], axis=1)
        state["x"], _ = em.step_rig(p, state["x"], inp, ext)
        state["k"] += 1

    return cpu_best(step, reps, rounds)


def env_case(params: ElpasParams | None, rounds: int) -> float:
    """CPU seconds per ``ELPAS-ForceTracking-v0`` ``env.step`` (voltage mode, random actions)."""
    import gymnasium as gym

    import vsa_gym  # noqa: F401  (registers the ids)

    env = gym.make("vsa_gym/ELPAS-ForceTracking-v0", params=params)
    env.reset(seed=0)
    acts = np.random.default_rng(1).uniform(-1.0, 1.0, (1000, 1)).astype(np.float32)
    cnt = {"k": 0}

    def step() -> None:
        _, _, term, trunc, _ = env.step(acts[cnt["k"] % 1000])
        cnt["k"] += 1
        if term or trunc:
            env.reset()

    return cpu_best(step, 1000, rounds)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rows", type=int, nargs="+", default=[1, 256])
    ap.add_argument("--rounds", type=int, default=3)
    args = ap.parse_args(argv)
    nominal = ElpasParams()
    hyst = nominal.replace(effects=ElpasEffects(M_h=M_H, phi_h=PHI_H))
    for n in args.rows:
        mixed = nominal.replace(effects=ElpasEffects(M_h=np.where(np.arange(n) == 0, M_H, 0.0),
                                                     phi_h=np.full(n, PHI_H)))
        cases = (("compiled, nominal", nominal, (), 500 if n == 1 else 50),
                 ("compiled, hysteresis column", hyst, (), 500 if n == 1 else 50),
                 ("compiled, column carried, M_h = 0 in all rows but row 0", mixed, (), 500 if n == 1 else 50),
                 ("numpy Extension route", nominal, (NumpyDahl(M_H, PHI_H),), 50 if n == 1 else 10))
        for name, p, ext, reps in cases:
            t = rig_case(p, n, ext, reps, args.rounds)
            print(f"rig, {n} rows, {name}: {1e6 * t:.1f} us CPU per 1 ms step")
    for name, params in (("nominal", None), ("hysteresis column", hyst)):
        t = env_case(params, args.rounds)
        print(f"ELPAS-ForceTracking-v0 env.step, {name}: {1e6 * t:.1f} us CPU")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
