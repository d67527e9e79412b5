"""Simulator throughput against gym-electric-motor, with each core's integration error (issue 8).

Run::

    python -m benchmarks.throughput [--quick] [--json FILE] [--md FILE]

Measures, in one process on one machine:

* the peer: gym-electric-motor's ``Cont-CC-PermExDc-v0`` (continuous current control of a
  permanently excited DC motor on a rigid inertia) with its defaults, random actions,
  resets included (``peer_steps_per_s``), and the rate of its ``step`` calls alone
  (``peer_steps_per_s_no_reset``).  Install it with ``pip install -e .[bench]``; without it
  the ratios are left empty.
* every registered vsa-gym id as a single environment (``gym.make``: registry wrappers,
  random valid actions from the action space, resets included) at its default
  ``control_dt`` and at 1 ms;
* the native vector environment (``gym.make_vec``) of every id at ``n = 1, 64, 1024``,
  autoreset included; ``vector_env_steps_per_s`` is the headline id's (the vsaUT-II
  position/stiffness task), ``vector_env_steps_per_s_by_id`` all of them;
* identification: the wall time of ``Identifier().fit`` on a 20 s, 1 kHz synthetic drive
  record (``identify_20s_record_wall_s``), the drive replay speed, and the vsaUT-II core
  replaying 20 s at 1 kHz, in simulated seconds per wall second;
* the vsaUT-II ids again with the opt-in exponential integrator (``integrator="etd"``): single env at
  1 ms, vector at the largest ``n``, and its Radau error (``etd`` keys);
* the vsaUT-II core alone (``VsaUT2Model.step``, a 2 ms step, both integrators, n = 1 and the largest
  ``n``): rows per second, right-hand-side evaluations per step and CPU time per evaluation and row, the
  figures that bound what any environment on this core can reach (``core``);
* peak resident memory of the process;
* each environment's core at the environment's control step against the Radau reference
  (rtol 1e-9 for the vsaUT-II, 1e-7 for the eLPAS, as their tests), as the worst state
  error relative to that state's largest magnitude; the bound is 1e-3.

Every figure of ours is printed with its ratio to the peer's default env-steps/s.  The
machine is shared: absolute rates are noisy, so compare ratios measured in one run.
``--quick`` (CI) shortens every timing window and the accuracy runs; it asserts nothing
about speed.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import sys
import time
import warnings
from collections.abc import Callable
from typing import Any

import numpy as np

PEER_ID = "Cont-CC-PermExDc-v0"
HEADLINE_ID = "vsa_gym/VsaUT2-PositionStiffness-v0"
VECTOR_SIZES = (1, 64, 1024)
ACCURACY_BOUND = 1e-3


# ----------------------------------------------------------------------------- timing helpers
def _rate(step: Callable[[], int], window_s: float, min_calls: int = 3) -> tuple[float, float]:
    """Call ``step`` (returns env-steps done) for about ``window_s``.

    Returns ``(env-steps per wall second, env-steps per CPU second of this process)``; the
    second is far less sensitive to other load on a shared machine (for multi-threaded
    kernels it counts the CPU time of every thread).
    """
    steps, calls = 0, 0
    t0, c0 = time.perf_counter(), time.process_time()
    while True:
        steps += step()
        calls += 1
        el = time.perf_counter() - t0
        if calls >= min_calls and el >= window_s:
            return steps / el, steps / max(time.process_time() - c0, 1e-9)


def action_draws(space: Any, seed: int = 0, chunk: int = 100) -> Callable[[], np.ndarray]:
    """Uniform random actions from a bounded Box, drawn ``chunk`` at a time with one numpy call.

    ``space.sample()`` costs about as much as a whole compiled env step (40 us measured on the loaded 2-core
    machine); a policy's actions come from its network, not from the sampler, so the benchmark times the env
    with pre-drawn actions -- the same for the peer and for every env here.
    """
    rng = np.random.default_rng(seed)
    lo, hi = np.asarray(space.low, dtype=np.float64), np.asarray(space.high, dtype=np.float64)
    buf: list[np.ndarray] = []

    def draw() -> np.ndarray:
        if not buf:
            buf.extend(rng.uniform(lo, hi, size=(chunk, *lo.shape)).astype(space.dtype))
        return buf.pop()

    return draw


def peak_rss_mib() -> float:
    """Peak resident set size of this process so far (MiB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


# ----------------------------------------------------------------------------- the peer
def measure_peer(window_s: float) -> dict[str, Any]:
    try:
        import gym_electric_motor as gem
    except ImportError:
        return {"available": False, "reason": "gym-electric-motor not installed (pip install -e .[bench])"}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        env = gem.make(PEER_ID)
        env.reset(seed=0)
        action = action_draws(env.action_space)
        # warm-up (first calls build caches)
        for _ in range(50):
            _, _, term, trunc, _ = env.step(action())
            if term or trunc:
                env.reset()
        n, resets, t_step = 0, 0, 0.0
        t0, c0 = time.perf_counter(), time.process_time()
        while time.perf_counter() - t0 < window_s:
            a = action()
            ts = time.perf_counter()
            _, _, term, trunc, _ = env.step(a)
            t_step += time.perf_counter() - ts
            n += 1
            if term or trunc:
                env.reset()
                resets += 1
        wall = time.perf_counter() - t0
        cpu = time.process_time() - c0
    from importlib.metadata import version

    return {"available": True, "id": PEER_ID, "version": version("gym-electric-motor"),
            "steps_per_s": n / wall, "steps_per_cpu_s": n / cpu,
            "steps_per_s_no_reset": n / t_step, "steps": n, "resets": resets,
            "tau_s": float(env.unwrapped.physical_system.tau)}


# ----------------------------------------------------------------------------- our environments
def measure_single(env_id: str, window_s: float, **kwargs: Any) -> dict[str, Any]:
    import gymnasium as gym

    env = gym.make(env_id, **kwargs)
    env.reset(seed=0)
    action = action_draws(env.action_space)
    state = {"resets": 0}

    def chunk() -> int:
        for _ in range(100):
            _, _, term, trunc, _ = env.step(action())
            if term or trunc:
                env.reset()
                state["resets"] += 1
        return 100

    chunk()  # warm-up: compiled kernels load from numba's cache
    rate, cpu_rate = _rate(chunk, window_s)
    dt = float(env.unwrapped.task.control_dt)
    env.close()
    return {"steps_per_s": rate, "steps_per_cpu_s": cpu_rate, "control_dt": dt, "resets": state["resets"],
            "sim_s_per_wall_s": rate * dt}


def measure_vector(env_id: str, n: int, window_s: float, **kwargs: Any) -> dict[str, Any]:
    import gymnasium as gym

    env = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point", **kwargs)
    env.reset(seed=0)
    action = action_draws(env.action_space, chunk=10)

    def call() -> int:
        env.step(action())
        return n

    call()
    rate, cpu_rate = _rate(call, window_s)
    env.close()
    return {"steps_per_s": rate, "steps_per_cpu_s": cpu_rate}


def measure_core(window_s: float, sizes: tuple[int, ...]) -> dict[str, Any]:
    """The vsaUT-II core alone: a 2 ms ``step`` of ``n`` rows, held inputs, per integrator.

    ``cpu_us_per_rhs_row`` = CPU time per step / (rows x RHS evaluations per step): the cost of one
    evaluation of the equations of motion for one row, all threads counted.
    """
    from vsa_gym.devices.vsaut2.model import ETD_SUBSTEPS_PER_MS, SUBSTEPS_PER_MS, VsaUT2Model

    out: dict[str, Any] = {}
    for integ, per_ms in (("rk4", SUBSTEPS_PER_MS), ("etd", ETD_SUBSTEPS_PER_MS)):
        model = VsaUT2Model(integrator=integ)
        for n in sizes:
            x = model.initial_state(n, q1=0.02)
            u, tau = np.full((n, 2), 5.0), np.zeros(n)
            model.step(x, u, tau, 2e-3)

            def call(model: Any = model, x: np.ndarray = x, u: np.ndarray = u, tau: np.ndarray = tau,
                     n: int = n) -> int:
                model.step(x, u, tau, 2e-3)
                return n

            rate, cpu_rate = _rate(call, window_s)
            n_rhs = 4 * int(np.ceil(2.0 * per_ms))
            out[f"{integ}_n{n}"] = {"integrator": integ, "n": n, "rows_per_s": rate, "rows_per_cpu_s": cpu_rate,
                                    "rhs_per_step": n_rhs, "cpu_us_per_rhs_row": 1e6 / (cpu_rate * n_rhs)}
    return out


# ----------------------------------------------------------------------------- accuracy against Radau
def _worst_relative(xs: np.ndarray, ref: np.ndarray) -> float:
    scale = np.maximum(np.abs(ref).max(axis=0), 1e-9)
    return float(np.max(np.abs(xs - ref).max(axis=0) / scale))


def accuracy(env_id: str, n_steps: int, seed: int = 0, **kwargs: Any) -> dict[str, Any]:
    """The environment's own core (its parameters, control step, sub-steps, compiled or not) against Radau.

    Random commands (uniform in the action box, scaled as the environment's voltage mode
    does) held over each control step, from the state of a seeded reset.
    """
    import gymnasium as gym

    from vsa_gym.physics.integrate import reference_solution

    env = gym.make(env_id, **kwargs)
    env.reset(seed=seed)
    task = env.unwrapped.task
    rng = np.random.default_rng(seed)
    dt = task.control_dt
    x0 = task.s["x"][:1].copy()
    t0 = time.perf_counter()
    if "VsaUT2" in env_id:
        model = task.model
        p = task.params
        u = rng.uniform(-1, 1, (n_steps, 1, 2)) * np.array([p.pivot_motor.U_max, p.frame_motor.U_max])
        tau = rng.uniform(-0.5, 0.5, (n_steps, 1))
        xs, _ = model.simulate(x0, u, tau, dt)
        xs = xs[:, 0, :]
        ref, _ = reference_solution(lambda k: (lambda y: model.rhs(y, u[k], tau[k])), x0[0], dt, n_steps)
        rtol = 1e-9
    else:
        from vsa_gym.devices.elpas import model as em

        p = task.params
        vehicle = bool(task.vehicle)
        step = em.step_vehicle if vehicle else em.step_rig
        rhs = em.rhs_vehicle if vehicle else em.rhs_rig
        col = em.Y_R if vehicle else em.ALPHA
        volts = rng.uniform(-1, 1, n_steps) * float(p.motor.U_max)
        t = dt * np.arange(1, n_steps + 1)
        second = (0.01 * np.sin(2 * np.pi * 3.0 * t) if vehicle
                  else np.deg2rad(10.0) * np.sin(2 * np.pi * 2.0 * t))
        compiled = bool(getattr(task, "compiled", False))
        x, xs_l, starts = x0, [x0[0]], []
        for k in range(n_steps):
            starts.append(float(x[0, col]))
            x, _ = step(p, x, np.array([[volts[k], second[k]]]), compiled=compiled)
            xs_l.append(x[0])
        xs = np.array(xs_l)

        def factory(k: int) -> Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]:
            inp = np.array([[volts[k], (second[k] - starts[k]) / dt]])
            return lambda y: rhs(p, y, inp)

        ref = reference_solution(factory, x0[0], dt, n_steps, rtol=1e-7, atol=1e-10)[0]
        if vehicle:  # the road height is an input (set exactly at each step end), not integrated
            xs, ref = np.delete(xs, col, axis=1), np.delete(ref, col, axis=1)
        rtol = 1e-7
    env.close()
    err = _worst_relative(xs, ref)
    return {"worst_relative_state_error": err, "bound": ACCURACY_BOUND, "ok": bool(err <= ACCURACY_BOUND),
            "steps": n_steps, "control_dt": dt, "radau_rtol": rtol, "wall_s": time.perf_counter() - t0}


# ----------------------------------------------------------------------------- identification
def measure_identification(duration_s: float, window_s: float) -> dict[str, Any]:
    out: dict[str, Any] = {}
    # the vsaUT-II core replaying a record (what an identification of the actuator replays)
    from vsa_gym.devices.vsaut2.model import VsaUT2Model

    model = VsaUT2Model()
    T = int(round(duration_s / 1e-3))
    rng = np.random.default_rng(0)
    u = np.repeat(rng.uniform(-24, 24, (T // 50 + 1, 1, 2)), 50, axis=0)[:T]
    x0 = model.initial_state(1, q1=0.02)
    model.simulate(x0, u[:10])  # warm-up
    t0 = time.perf_counter()
    model.simulate(x0, u)
    wall = time.perf_counter() - t0
    out["vsaut2_replay_sim_s_per_wall_s"] = duration_s / wall
    try:
        from vsa_gym.devices.drive.adapter import DriveAdapter
        from vsa_gym.devices.drive.synthetic import make_drive_record
        from vsa_gym.identify.pipeline import Identifier
    except ImportError as exc:  # the workbench is optional here
        out["identify_available"] = False
        out["identify_reason"] = f"vsa_gym.identify not importable: {exc}"
        return out
    rec, truth = make_drive_record(1, "coulomb_friction", duration=duration_s, dt=1e-3)
    ad = DriveAdapter(rec)
    theta: dict[str, np.ndarray] = {}
    for n in (1, 64):
        ad.simulate(theta, n)
        rate, _ = _rate(lambda n=n: (ad.simulate(theta, n), n)[1], window_s, min_calls=2)
        out[f"drive_replay_n{n}_sim_s_per_wall_s"] = rate * duration_s
    t0 = time.perf_counter()
    res = Identifier().fit(rec).result_
    out["identify_wall_s"] = time.perf_counter() - t0
    out["identify_record_s"] = duration_s
    out["identify_effects"] = [e["name"] for e in res.effects] if res is not None else []
    out["identify_truth"] = truth["effect"]
    out["identify_available"] = True
    return out


# ----------------------------------------------------------------------------- report
def machine() -> dict[str, Any]:
    cpu = platform.processor() or ""
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    import numba

    load = os.getloadavg() if hasattr(os, "getloadavg") else (float("nan"),) * 3
    return {"cpu": cpu, "cores": os.cpu_count(), "python": platform.python_version(),
            "numpy": np.__version__, "numba": numba.__version__, "platform": platform.platform(),
            "numba_threads": numba.config.NUMBA_NUM_THREADS, "load_avg_1_5_15": [round(v, 2) for v in load]}


def _fmt(v: float | None, digits: int = 3) -> str:
    if v is None:
        return "-"
    if v >= 100:
        return f"{v:,.0f}"
    return f"{v:.{digits}g}"


def markdown(res: dict[str, Any]) -> str:
    peer = res["peer_steps_per_s"]
    peer_cpu = res.get("peer", {}).get("steps_per_cpu_s")

    def ratio(v: float | None, ref: float | None = None) -> str:
        ref = peer if ref is None else ref
        return "-" if (v is None or not ref) else f"{v / ref:.1f}x"

    acc = res["accuracy"]
    lines = [
        f"Command: `{res['command']}`  ",
        f"Machine: {res['machine']['cpu']}, {res['machine']['cores']} cores, load average at start "
        f"{res['machine']['load_avg_1_5_15']} (shared), Python {res['machine']['python']}, "
        f"numpy {res['machine']['numpy']}, numba {res['machine']['numba']}  ",
        f"Peer: gym-electric-motor {res.get('peer', {}).get('version', '-')} `{PEER_ID}` defaults: "
        f"{_fmt(peer)} env-steps/s with resets ({_fmt(peer_cpu)} per CPU second), "
        f"{_fmt(res.get('peer_steps_per_s_no_reset'))} in step() alone",
        "",
        "| what | control step | env-steps/s (wall) | x peer (wall) | env-steps per CPU s | x peer (CPU) "
        "| worst rel. error vs Radau (bound 1e-3) |",
        "|---|---|---|---|---|---|---|",
    ]
    for env_id, r in res["single"].items():
        a = acc.get(env_id, {})
        err = f"{a['worst_relative_state_error']:.1e}" if a else "-"
        lines.append(f"| single `{env_id.split('/')[-1]}` | {1e3 * r['control_dt']:g} ms | {_fmt(r['steps_per_s'])} | "
                     f"{ratio(r['steps_per_s'])} | {_fmt(r['steps_per_cpu_s'])} | "
                     f"{ratio(r['steps_per_cpu_s'], peer_cpu)} | {err} |")
        r1 = res["single_1ms"].get(env_id)
        if r1 is not None and abs(r1["control_dt"] - r["control_dt"]) > 1e-12:
            lines.append(f"| single `{env_id.split('/')[-1]}` | 1 ms | {_fmt(r1['steps_per_s'])} | "
                         f"{ratio(r1['steps_per_s'])} | {_fmt(r1['steps_per_cpu_s'])} | "
                         f"{ratio(r1['steps_per_cpu_s'], peer_cpu)} | |")
    for env_id, by_n in res["vector"].items():
        for n, r in by_n.items():
            lines.append(f"| vector n={n} `{env_id.split('/')[-1]}` | default | {_fmt(r['steps_per_s'])} | "
                         f"{ratio(r['steps_per_s'])} | {_fmt(r['steps_per_cpu_s'])} | "
                         f"{ratio(r['steps_per_cpu_s'], peer_cpu)} | |")
    for env_id, e in res.get("etd", {}).items():
        name = env_id.split("/")[-1]
        a = e["accuracy"]
        r1 = e["single_1ms"]
        lines.append(f"| single `{name}`, `integrator=\"etd\"` | 1 ms | {_fmt(r1['steps_per_s'])} | "
                     f"{ratio(r1['steps_per_s'])} | {_fmt(r1['steps_per_cpu_s'])} | "
                     f"{ratio(r1['steps_per_cpu_s'], peer_cpu)} | |")
        for n, r in e["vector"].items():  # the error is measured at the default control step, as for rk4
            lines.append(f"| vector n={n} `{name}`, `integrator=\"etd\"` | default | {_fmt(r['steps_per_s'])} | "
                         f"{ratio(r['steps_per_s'])} | {_fmt(r['steps_per_cpu_s'])} | "
                         f"{ratio(r['steps_per_cpu_s'], peer_cpu)} | {a['worst_relative_state_error']:.1e} |")
    for env_id, by_n in res.get("parallel_rows", {}).items():
        for n, r in by_n.items():
            lines.append(f"| vector n={n} `{env_id.split('/')[-1]}`, `parallel_rows=True` | default | "
                         f"{_fmt(r['steps_per_s'])} | {ratio(r['steps_per_s'])} | {_fmt(r['steps_per_cpu_s'])} | "
                         f"{ratio(r['steps_per_cpu_s'], peer_cpu)} | |")
    idr = res["identification"]
    lines += ["", "| identification | value |", "|---|---|",
              f"| vsaUT-II core replay, n=1, 1 ms steps | {_fmt(idr['vsaut2_replay_sim_s_per_wall_s'])} "
              "simulated s per wall s |"]
    if idr.get("identify_available"):
        for n in (1, 64):
            lines.append(f"| drive replay, n={n} candidates | {_fmt(idr[f'drive_replay_n{n}_sim_s_per_wall_s'])} "
                         "simulated s per wall s |")
        lines.append(f"| `Identifier().fit` on a {idr['identify_record_s']:g} s, 1 kHz record | "
                     f"{idr['identify_wall_s']:.1f} s wall (effects named: {idr['identify_effects']}, "
                     f"planted: {idr['identify_truth']}) |")
    else:
        lines.append(f"| identification | not measured: {idr.get('identify_reason')} |")
    lines.append(f"| peak RSS of the benchmark process | {res['peak_rss_mib']:.0f} MiB |")
    lines += ["", "| vsaUT-II core alone, 2 ms step | rows x steps/s (wall) | per CPU s | RHS evaluations per step "
              "| CPU us per RHS and row | 2-core ceiling if the env cost nothing |", "|---|---|---|---|---|---|"]
    for c in res.get("core", {}).values():
        ceiling = 2e6 / (c["cpu_us_per_rhs_row"] * c["rhs_per_step"])
        lines.append(f"| `{c['integrator']}`, n={c['n']} | {_fmt(c['rows_per_s'])} | {_fmt(c['rows_per_cpu_s'])} | "
                     f"{c['rhs_per_step']} | {c['cpu_us_per_rhs_row']:.2f} | {_fmt(ceiling)} env-steps/s |")
    return "\n".join(lines)


def run(quick: bool = False, ids: list[str] | None = None, sizes: tuple[int, ...] = VECTOR_SIZES) -> dict[str, Any]:
    import vsa_gym  # noqa: F401  (registers the ids)
    from vsa_gym.envs import ENV_IDS

    ids = list(ENV_IDS) if ids is None else ids
    window = 0.5 if quick else 3.0
    res: dict[str, Any] = {"quick": quick, "machine": machine(),
                           "command": "python -m benchmarks.throughput" + (" --quick" if quick else "")}
    peer = measure_peer(window)
    res["peer"] = peer
    res["peer_steps_per_s"] = peer.get("steps_per_s")
    res["peer_steps_per_s_no_reset"] = peer.get("steps_per_s_no_reset")
    res["single"] = {i: measure_single(i, window) for i in ids}
    res["single_1ms"] = {i: measure_single(i, window, control_dt=1e-3) for i in ids}
    res["single_env_steps_per_s"] = {i: r["steps_per_s"] for i, r in res["single"].items()}
    res["single_env_1ms_steps_per_s"] = {i: r["steps_per_s"] for i, r in res["single_1ms"].items()}
    res["vector"] = {i: {n: measure_vector(i, n, window) for n in sizes} for i in ids}
    by_id = {i: {n: r["steps_per_s"] for n, r in d.items()} for i, d in res["vector"].items()}
    res["vector_env_steps_per_s_by_id"] = by_id
    res["vector_env_steps_per_s"] = by_id.get(HEADLINE_ID, next(iter(by_id.values())))
    res["vector_headline_id"] = HEADLINE_ID if HEADLINE_ID in by_id else ids[0]
    res["core"] = measure_core(window, (1, max(sizes)))
    res["identification"] = measure_identification(2.0 if quick else 20.0, window)
    res["identify_20s_record_wall_s"] = (res["identification"].get("identify_wall_s") if not quick else None)
    res["accuracy"] = {i: accuracy(i, 20 if quick else 100) for i in ids}
    n_big = max(sizes)
    res["etd"] = {i: {"single_1ms": measure_single(i, window, control_dt=1e-3, integrator="etd"),
                      "vector": {n_big: measure_vector(i, n_big, window, integrator="etd")},
                      "accuracy": accuracy(i, 20 if quick else 100, integrator="etd")}
                  for i in ids if "VsaUT2" in i}
    res["parallel_rows"] = {i: {n_big: measure_vector(i, n_big, window, parallel_rows=True)}
                            for i in ids if "ELPAS" in i}
    res["accuracy_ok"] = all(a["ok"] for a in res["accuracy"].values()) and \
        all(e["accuracy"]["ok"] for e in res["etd"].values())
    res["peak_rss_mib"] = peak_rss_mib()
    if res["peer_steps_per_s"]:
        p = res["peer_steps_per_s"]
        res["ratios_to_peer"] = {
            "single": {i: v / p for i, v in res["single_env_steps_per_s"].items()},
            "single_1ms": {i: v / p for i, v in res["single_env_1ms_steps_per_s"].items()},
            "vector": {i: {n: v / p for n, v in d.items()} for i, d in by_id.items()},
        }
    return res


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="short timing windows and accuracy runs (CI)")
    ap.add_argument("--json", type=str, default=None, help="write the results as JSON to this file")
    ap.add_argument("--md", type=str, default=None, help="write the markdown table to this file")
    ap.add_argument("--ids", nargs="*", default=None, help="only these ids (default: all registered)")
    ap.add_argument("--sizes", nargs="*", type=int, default=None, help="vector sizes (default 1 64 1024)")
    args = ap.parse_args(argv)
    res = run(args.quick, args.ids, tuple(args.sizes) if args.sizes else VECTOR_SIZES)
    table = markdown(res)
    print(table)
    if args.md:
        with open(args.md, "w") as f:
            f.write(table + "\n")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(res, f, indent=2, default=str)
    if not res["accuracy_ok"]:
        print("integration error above the bound:", {k: v["worst_relative_state_error"]
                                                     for k, v in res["accuracy"].items() if not v["ok"]},
              file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
