"""Speed of the eLPAS core, its environments' step and the identification replay, before against after a change.

    python -m benchmarks.elpas_core_speed                       (this checkout only)
    python -m benchmarks.elpas_core_speed --against DIR [--rounds R]

With ``--against DIR`` (another checkout of the project, e.g. the commit a change started from) each round runs
one fresh interpreter per checkout, alternating (``DIR``, this one, ``DIR``, ...), so that both see the same machine
load; every figure is the best of its rounds (microseconds per call) and the last column is
``time(DIR) / time(this)`` (> 1: this checkout is faster).  The other checkout is only read: its bytecode and numba
caches go to a temporary directory (``PYTHONPYCACHEPREFIX``, ``NUMBA_CACHE_DIR``).  Each interpreter warms every
kernel first (the first run in a fresh checkout compiles them: minutes on a 2-core machine).

Timed (one thread, ``time.perf_counter``, best of 3 repeats within an interpreter):

* ``rig nN compiled``: ``model.step_rig(..., compiled=True)`` on ``N`` rows (0.1 ms step, random voltage, alpha sine);
* ``rig nN default``: the same with the default ``compiled=False``;
* ``rig nN dahl``: with the arm hysteresis (Dahl): before issue 17 a ``DahlHysteresis`` extension (the Python-level
  path), since the compiled core's state column (``effects.M_h``);
* ``vehicle n1 compiled``: ``model.step_vehicle`` on one row;
* ``env voltage`` / ``env current``: ``ELPAS-ForceTracking-v0`` ``env.step`` (``gym.make``, default control step);
* ``replay nN``: :class:`~vsa_gym.devices.elpas.adapter.ElpasAdapter` ``simulate`` of a 0.3 s synthetic record
  on ``N`` candidate rows (the 10 kHz current loop and the core), per call.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np


def _best(fn: Callable[[], None], calls: int, repeats: int = 3) -> float:
    """Best over ``repeats`` of the mean time of one of ``calls`` calls (us)."""
    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        for _ in range(calls):
            fn()
        best = min(best, (time.perf_counter() - t0) / calls)
    return best * 1e6


def _dahl(p: Any) -> tuple[Any, tuple]:
    """The arm hysteresis (M_h = 20 N m, sigma = 2000 N m/rad) as this checkout runs it: ``(params, extensions)``.
    Before issue 17 a numpy ``DahlHysteresis`` extension; since, the compiled core's state column
    (``effects.M_h``, ``phi_h = M_h / sigma``)."""
    try:
        from vsa_gym.devices.elpas.extensions import DahlHysteresis  # type: ignore[attr-defined]
    except ImportError:
        from vsa_gym.devices.elpas.params import ElpasEffects

        return p.replace(effects=ElpasEffects(M_h=20.0, phi_h=0.01)), ()
    return p, (DahlHysteresis(M_h=20.0, sigma=2000.0),)


def measure() -> dict[str, float]:
    """Time this interpreter's checkout (see the module docstring); microseconds per call."""
    import gymnasium as gym

    import vsa_gym
    from vsa_gym.devices.elpas import model as em
    from vsa_gym.devices.elpas.params import ElpasParams

    out: dict[str, float] = {}
    p = ElpasParams()
    p = p.replace(numerics=p.numerics.replace(dt=1e-4, n_sub=1.0))
    rng = np.random.default_rng(0)
    for n, calls in ((1, 1000), (256, 100)):
        volts = rng.uniform(-42.0, 42.0, (calls, n))
        alpha = np.radians(8.0) * np.sin(np.linspace(0.0, 6.0, calls))[:, None] * np.ones(n)
        inputs = [np.stack([volts[k], alpha[k]], axis=1) for k in range(calls)]
        p_dahl, dahl = _dahl(p)
        for tag, kw, ext, pp in (("compiled", {"compiled": True}, (), p), ("default", {}, (), p),
                                 ("dahl", {}, dahl, p_dahl)):
            # the numpy paths of the original code are slow on many rows
            calls_t = 20 if tag != "compiled" and n > 1 and calls > 20 else calls
            state = {"x": em.initial_state_rig(pp, n, gamma=0.3, extensions=ext), "k": 0}

            def step(kw: dict = kw, ext: tuple = ext, state: dict = state, calls_t: int = calls_t, n: int = n,
                     inputs: list = inputs, pp: Any = pp) -> None:
                k = state["k"] % calls_t
                if k == 0:
                    state["x"] = em.initial_state_rig(pp, n, gamma=0.3, extensions=ext)
                state["x"], _ = em.step_rig(pp, state["x"], inputs[k], ext, **kw)
                state["k"] += 1

            step()  # warm-up (compilation or cache load)
            out[f"rig n{n} {tag}"] = _best(step, calls_t)
    xv = {"x": em.initial_state_vehicle(p, 1), "k": 0}
    road = 0.01 * np.sin(np.linspace(0.0, 6.0, 1000))

    def vstep() -> None:
        xv["x"], _ = em.step_vehicle(p, xv["x"], np.array([[10.0, road[xv["k"] % 1000]]]), compiled=True)
        xv["k"] += 1

    vstep()
    out["vehicle n1 compiled"] = _best(vstep, 1000)
    for mode in ("voltage", "current"):
        env = gym.make("vsa_gym/ELPAS-ForceTracking-v0", control_mode=mode)
        env.reset(seed=0)
        acts = np.random.default_rng(1).uniform(-1.0, 1.0, (1000, 1)).astype(np.float32)
        cnt = {"k": 0}

        def estep(env: gym.Env = env, acts: np.ndarray = acts, cnt: dict = cnt) -> None:
            _, _, term, trunc, _ = env.step(acts[cnt["k"] % 1000])
            cnt["k"] += 1
            if term or trunc:
                env.reset()

        for _ in range(20):
            estep()
        out[f"env {mode}"] = _best(estep, 1000)
        env.close()
    from vsa_gym.devices.elpas.synthetic import make_elpas_record

    rec, _ = make_elpas_record(2, "coulomb_friction", duration=0.3)
    from vsa_gym.devices.elpas.adapter import ElpasAdapter

    ad = ElpasAdapter(rec)
    for n in (1, 16):
        theta = {"coulomb_friction.F_c": np.linspace(0.0, 0.1, n)}
        ad.simulate(theta, n)
        out[f"replay n{n}"] = _best(lambda theta=theta, n=n: ad.simulate(theta, n), 3)
    out["_file"] = vsa_gym.__file__  # type: ignore[assignment]
    return out


def main(argv: list[str] | None = None) -> None:
    # imported here: measure() also runs in checkouts that lack this module
    from benchmarks.checkouts import compare, speed_parser

    args = speed_parser(__doc__).parse_args(argv)
    compare(Path(__file__), args.against, args.rounds, "us per call", cache_env="ELPAS_SPEED_CACHE")


if __name__ == "__main__":
    main()
