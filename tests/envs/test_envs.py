"""Tests of the registered Gymnasium environments (single, native vector, SB3 adapter)."""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gym_check_env
from stable_baselines3.common.env_checker import check_env as sb3_check_env

import vsa_gym  # noqa: F401  (registers the ids)
from vsa_gym.devices.vsaut2.model import POWER, VsaUT2Model
from vsa_gym.envs import ENV_IDS

IDS = list(ENV_IDS)


def _actions(env_id: str, n_steps: int, seed: int = 0, n: int | None = None) -> np.ndarray:
    m = 2 if "VsaUT2" in env_id else 1
    shape = (n_steps, m) if n is None else (n_steps, n, m)
    return np.random.default_rng(seed).uniform(-1.0, 1.0, shape)


def _rollout(env: gym.Env, actions: np.ndarray) -> tuple[list[np.ndarray], list[float], list[dict]]:
    obs, rews, infos = [], [], []
    for a in actions:
        o, r, term, trunc, info = env.step(a)
        obs.append(o)
        rews.append(r)
        infos.append(info)
        if term or trunc:
            o, _ = env.reset()
            obs.append(o)
    return obs, rews, infos


@pytest.mark.parametrize("env_id", IDS)
def test_checkers_pass(env_id: str) -> None:
    env = gym.make(env_id)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # any checker warning fails the test
        gym_check_env(env.unwrapped, skip_render_check=True)
        sb3_check_env(gym.make(env_id), warn=True)
    assert env.spec is not None and env.spec.max_episode_steps is not None


@pytest.mark.parametrize("env_id", IDS)
def test_same_seed_same_rollout_also_after_unseeded_reset(env_id: str) -> None:
    acts = _actions(env_id, 40)
    runs = []
    for seed in (7, 7, 8):
        env = gym.make(env_id, sensor_noise=True)  # noise makes even the deterministic-start Throw seed-dependent
        o0, _ = env.reset(seed=seed)
        obs1, r1, _ = _rollout(env, acts[:20])
        o1, _ = env.reset()  # no seed: continues the seeded stream
        obs2, r2, _ = _rollout(env, acts[20:])
        runs.append((np.concatenate([o0[None], np.array(obs1), o1[None], np.array(obs2)]), np.array(r1 + r2)))
    np.testing.assert_array_equal(runs[0][0], runs[1][0])
    np.testing.assert_array_equal(runs[0][1], runs[1][1])
    assert not np.array_equal(runs[0][0], runs[2][0]), "a different seed must give a different episode"


@pytest.mark.parametrize("env_id", IDS)
def test_vector_equals_single_envs(env_id: str) -> None:
    n, limit, steps = 3, 15, 25
    acts = _actions(env_id, steps, seed=1, n=n)
    venv = gym.make_vec(env_id, num_envs=n, max_episode_steps=limit)
    vo, _ = venv.reset(seed=100)
    v_obs, v_rew, v_e = [vo], [], []
    for k in range(steps):
        o, r, term, trunc, info = venv.step(acts[k])
        v_obs.append(o)
        v_rew.append(r)
        v_e.append(info["energy_el"])
    assert np.any(trunc) or k >= limit  # the time limit was crossed (autoreset exercised)
    for i in range(n):
        env = gym.make(env_id, max_episode_steps=limit)
        o, _ = env.reset(seed=100 + i)
        np.testing.assert_allclose(o, v_obs[0][i], rtol=0, atol=1e-12)
        done = False
        for k in range(steps):
            if done:  # next-step autoreset of the vector env
                o, _ = env.reset()
                r, e = 0.0, 0.0
                done = False
            else:
                o, r, term, trunc, info = env.step(acts[k, i])
                e = info["energy_el"]
                done = term or trunc
            np.testing.assert_allclose(o, v_obs[k + 1][i], rtol=1e-12, atol=1e-12)
            assert abs(r - v_rew[k][i]) <= 1e-12 * max(1.0, abs(r))
            assert abs(e - v_e[k][i]) <= 1e-12 * max(1.0, abs(e))


@pytest.mark.parametrize("hysteresis", [False, True])
def test_energy_term_is_core_integral_of_electrical_power_vsaut2(hysteresis: bool) -> None:
    """The env's energy term is the core's integral of the electrical power; with spring hysteresis on (its state
    an extra column of the env's core state) the env's own state trajectory also closes the core's energy balance,
    with the Dahl element's dissipation in the ``viscous`` channel and its stored part in ``stored_energy``."""
    from vsa_gym.devices.vsaut2.params import VsaUT2Effects, VsaUT2Params

    params = VsaUT2Params(effects=VsaUT2Effects(M_h=0.05, phi_h=0.002)) if hysteresis else None
    env = gym.make("vsa_gym/VsaUT2-PositionStiffness-v0", regen="count", w_energy=2.0, params=params)
    env.reset(seed=3)
    task = env.unwrapped.task
    model = VsaUT2Model(task.params)
    assert task.s["x"].shape == (1, 11 if hysteresis else 10) == (1, model.n_states)
    total_env, total_ref, h_seen, imbalance, scale = 0.0, 0.0, 0.0, 0.0, 0.0
    for a in _actions("vsa_gym/VsaUT2-PositionStiffness-v0", 30, seed=4):
        x0, tau = task.s["x"].copy(), task.s["tau"].copy()
        _, _, term, _, info = env.step(a)
        u = np.clip(a, -1, 1) * np.array([task.params.pivot_motor.U_max, task.params.frame_motor.U_max])
        # the core's own integral of u_eff i over the step (exact bookkeeping) ...
        _, e = model.step(x0, u[None], tau, task.control_dt)
        e_core = e[0, POWER["el_pivot"]] + e[0, POWER["el_frame"]]
        assert info["energy_el"] == pytest.approx(e_core, rel=1e-12, abs=1e-15)
        # energy in - dissipated - stored, over the env's own step (summed: RK4's per-step error at a voltage
        # jump is larger than over the run)
        imbalance += e[0, :3].sum() - e[0, 3:].sum() - (model.stored_energy(task.s["x"]) - model.stored_energy(x0))[0]
        scale += np.abs(e[0]).sum()
        if hysteresis:
            h_seen = max(h_seen, abs(task.s["x"][0, 10]))
        # ... and an independent 10x finer integral (the core's accuracy bound is 1e-3)
        _, e = model.step(x0, u[None], tau, task.control_dt, n_sub=200)
        e_ref = e[0, POWER["el_pivot"]] + e[0, POWER["el_frame"]]
        assert info["reward_energy"] == pytest.approx(-2.0 * info["energy_el"], rel=1e-12)
        assert info["energy_el"] == pytest.approx(e_ref, rel=1e-3, abs=1e-7)
        total_env += info["energy_el"]
        total_ref += e_ref
        assert not term
    assert info["energy_el_total"] == pytest.approx(total_env, rel=1e-12)
    assert total_env == pytest.approx(total_ref, rel=1e-3)
    assert abs(total_env) > 1e-3  # the check is not vacuous
    # RK4's error over the run (5.9e-4 of the flows, with and without hysteresis: measured when written)
    assert abs(imbalance) <= 1e-3 * scale
    assert (h_seen > 0.5 * 0.05) == hysteresis  # the hysteresis state went over most of its loop


def test_energy_term_elpas_and_regen_policy() -> None:
    from vsa_gym.devices.elpas import model as em

    for regen in ("count", "clip"):
        env = gym.make("vsa_gym/ELPAS-ForceTracking-v0", regen=regen, w_energy=1e-3)
        env.reset(seed=5)
        task = env.unwrapped.task
        fine = task.params.replace(numerics=task.params.numerics.replace(n_sub=40.0))
        saw_regen = False
        for k, a in enumerate(_actions("vsa_gym/ELPAS-ForceTracking-v0", 60, seed=6)):
            a = np.array([np.sin(0.3 * k)])  # reversals: motoring and regenerating steps
            x0 = task.s["x"].copy()
            t_new = task.s["t"] + task.control_dt
            alpha_end = task.alpha_sig.value(task.s, t_new)
            _, _, _, _, info = env.step(a)
            inp = np.array([[a[0] * task.params.motor.U_max, alpha_end[0]]])
            _, e = em.step_rig(task.params, x0, inp, compiled=True)  # the core's integral: exact bookkeeping
            assert info["energy_el"] == pytest.approx(e[0, em.P_EL], rel=1e-12, abs=1e-15)
            _, e = em.step_rig(fine, x0, inp)  # independent 10x finer integral
            assert info["energy_el"] == pytest.approx(e[0, em.P_EL], rel=1e-3, abs=1e-6)
            charged = info["energy_el"] if regen == "count" else max(info["energy_el"], 0.0)
            assert info["reward_energy"] == pytest.approx(-1e-3 * charged / task.control_dt, rel=1e-12, abs=1e-15)
            saw_regen |= info["energy_el"] < 0
        assert saw_regen, "the sequence must include regenerating steps for the policy check to mean anything"


@pytest.mark.parametrize("env_id", IDS)
def test_bad_actions_raise_or_clip_without_corrupting_state(env_id: str) -> None:
    env = gym.make(env_id)
    env.reset(seed=0)
    task = env.unwrapped.task
    before = {k: v.copy() for k, v in task.s.items()}
    m = env.action_space.shape[0]
    for bad in (np.nan, np.inf, -np.inf):
        a = np.zeros(m)
        a[m - 1] = bad
        with pytest.raises(ValueError, match=f"component {m - 1}"):
            env.step(a)
        for k, v in before.items():
            np.testing.assert_array_equal(task.s[k], v, err_msg=f"state {k!r} changed by a rejected action")
    with pytest.raises(ValueError):
        env.step(np.zeros(m + 1))
    # out-of-range values are clipped: same result as the box edge
    twin = gym.make(env_id)
    twin.reset(seed=0)
    big = np.full(m, 7.5)
    big[0] = -3.0
    o1, r1, _, _, i1 = env.step(big)
    o2, r2, _, _, i2 = twin.step(np.clip(big, -1, 1))
    np.testing.assert_array_equal(o1, o2)
    assert r1 == r2 and i1["action_clipped"] and not i2["action_clipped"]


@pytest.mark.parametrize("env_id", IDS)
def test_render_rgb_array_shape(env_id: str) -> None:
    env = gym.make(env_id, render_mode="rgb_array")
    env.reset(seed=0)
    for a in _actions(env_id, 5):
        env.step(a)
    frame = env.render()
    h, w = env.unwrapped.render_size
    assert isinstance(frame, np.ndarray) and frame.shape == (h, w, 3) and frame.dtype == np.uint8
    assert frame.std() > 1.0  # something was drawn
    env.close()


@pytest.mark.parametrize("env_id", IDS)
@pytest.mark.parametrize("policy", ["random", "zero"])
def test_10000_steps_without_nan(env_id: str, policy: str) -> None:
    n, steps = 50, 200  # 10 000 env steps through the native vector env
    venv = gym.make_vec(env_id, num_envs=n)
    obs, _ = venv.reset(seed=11)
    rng = np.random.default_rng(0)
    ends = 0
    for _ in range(steps):
        a = rng.uniform(-1, 1, venv.action_space.shape) if policy == "random" else np.zeros(venv.action_space.shape)
        obs, r, term, trunc, info = venv.step(a)
        assert np.all(np.isfinite(obs)) and np.all(np.isfinite(r))
        assert np.all(np.isfinite(venv.unwrapped.task.s["x"]))
        ends += int(np.sum(term | trunc))
    assert venv.observation_space.contains(obs)
    # and the single env on the same id
    env = gym.make(env_id)
    env.reset(seed=1)
    for _ in range(200):
        a = env.action_space.sample() if policy == "random" else np.zeros(env.action_space.shape)
        o, r, term, trunc, _ = env.step(a)
        assert np.all(np.isfinite(o)) and np.isfinite(r)
        if term or trunc:
            env.reset()


def test_info_reward_components_sum_to_reward() -> None:
    for env_id in IDS:
        env = gym.make(env_id)
        env.reset(seed=2)
        for a in _actions(env_id, 10):
            _, r, term, trunc, info = env.step(a)
            comps = [v for k, v in info.items() if k.startswith("reward_")]
            assert len(comps) >= 2
            assert sum(comps) == pytest.approx(r, rel=1e-12, abs=1e-12)
            assert any(k.startswith("margin_") for k in info) and "energy_el" in info
            if term or trunc:
                break


def test_domain_randomization_and_params_plug_in() -> None:
    from vsa_gym.devices.vsaut2.params import VsaUT2Params

    env = gym.make("vsa_gym/VsaUT2-PositionStiffness-v0", domain_randomization={"I_o": (0.005, 0.02)})
    env.reset(seed=0)
    a = env.unwrapped.task.params.I_o
    env.reset(seed=1)
    b = env.unwrapped.task.params.I_o
    assert 0.005 <= float(np.asarray(a).ravel()[0]) <= 0.02 and not np.array_equal(a, b)
    with pytest.raises(ValueError, match="not a parameter"):
        gym.make("vsa_gym/VsaUT2-PositionStiffness-v0", domain_randomization={"nonsense": (0, 1)})
    heavy = VsaUT2Params().replace(I_o=0.05)
    env2 = gym.make("vsa_gym/VsaUT2-Throw-v0", params=heavy)
    env2.reset(seed=0)
    assert env2.unwrapped.task.params.I_o == 0.05



def _check_randomised_effect_column(env_id: str, m_h: tuple[float, float], column: int) -> None:
    """A randomised stateful effect (``effects.M_h``): the vector env carries its state column, which moves,
    and equals single envs of the same seeds step by step; randomised to (0, 0) the column stays exactly 0."""
    dr = {"effects.M_h": m_h}
    venv = gym.make_vec(env_id, num_envs=3, domain_randomization=dr)
    venv.reset(seed=7)
    acts = _actions(env_id, 40, seed=5, n=3)
    v_obs = [venv.step(acts[k])[0] for k in range(40)]
    x = venv.unwrapped.task.s["x"]
    assert x.shape == (3, column + 1) and np.all(np.abs(x[:, column]) > 0.0)
    for i in range(3):
        env = gym.make(env_id, domain_randomization=dr)
        env.reset(seed=7 + i)
        for k in range(40):
            o = env.step(acts[k, i])[0]
            np.testing.assert_allclose(o, v_obs[k][i], rtol=1e-12, atol=1e-12)
    off = gym.make(env_id, domain_randomization={"effects.M_h": (0.0, 0.0)})
    off.reset(seed=0)
    for a in _actions(env_id, 20, seed=1):
        off.step(a)
    assert off.unwrapped.task.s["x"].shape == (1, column + 1) and off.unwrapped.task.s["x"][0, column] == 0.0


def test_spring_hysteresis_state_column_in_the_vsaut2_envs() -> None:
    """Spring hysteresis on (params, or randomised over its switch ``effects.M_h``): the core state of every row has
    the hysteresis column; rows drawn with ``M_h = 0`` keep it at exactly 0; a vector env equals single envs."""
    from vsa_gym.devices.vsaut2.params import VsaUT2Effects, VsaUT2Params

    p = VsaUT2Params(effects=VsaUT2Effects(M_h=0.03))
    env = gym.make("vsa_gym/VsaUT2-Throw-v0", params=p)
    env.reset(seed=0)
    for a in _actions("vsa_gym/VsaUT2-Throw-v0", 50, seed=2):
        env.step(a)
    x = env.unwrapped.task.s["x"]
    assert x.shape == (1, 11) and 0.0 < abs(x[0, 10]) <= 0.03
    _check_randomised_effect_column("vsa_gym/VsaUT2-PositionStiffness-v0", (0.0, 0.05), column=10)


def test_current_mode_runs_and_differs_from_voltage_mode() -> None:
    for env_id in ("vsa_gym/VsaUT2-Throw-v0", "vsa_gym/ELPAS-ForceTracking-v0"):
        outs = []
        for mode in ("voltage", "current"):
            env = gym.make(env_id, control_mode=mode)
            env.reset(seed=0)
            for a in _actions(env_id, 20):
                o, *_ = env.step(a * 0.2)
            outs.append(o)
            assert np.all(np.isfinite(o))
        assert not np.allclose(outs[0], outs[1])


def test_sb3_adapter_and_five_line_training() -> None:
    from stable_baselines3 import PPO

    from vsa_gym.envs.sb3 import make_sb3_vec_env

    venv = make_sb3_vec_env("vsa_gym/ELPAS-ForceTracking-v0", n_envs=4, seed=0, max_episode_steps=10)
    obs = venv.reset()
    assert obs.shape == (4, 8)
    for _ in range(10):
        obs, r, done, infos = venv.step(np.zeros((4, 1)))
    assert done.all() and all("terminal_observation" in d and d["TimeLimit.truncated"] for d in infos)
    env = gym.make("vsa_gym/ELPAS-ForceTracking-v0")
    PPO("MlpPolicy", env, n_steps=64, batch_size=32, n_epochs=1, seed=0).learn(128)


@pytest.mark.parametrize("randomized", [False, True])
def test_compiled_vsaut2_sensing_equals_the_sensor_models(randomized: bool) -> None:
    """The env's compiled per-step sensing gives what the sensor objects and the model's numpy functions give."""
    from vsa_gym.devices.vsaut2.lever import spring_stiffness
    from vsa_gym.devices.vsaut2.pivot import pivot_position

    kw = {"domain_randomization": {"lever.k": (1500.0, 2200.0)}} if randomized else {}
    venv = gym.make_vec("vsa_gym/VsaUT2-PositionStiffness-v0", num_envs=3, vectorization_mode="vector_entry_point",
                        **kw)
    venv.reset(seed=11)
    task = venv.unwrapped.task
    for a in _actions("vsa_gym/VsaUT2-PositionStiffness-v0", 60, seed=2, n=3):
        venv.step(a)
        np.testing.assert_array_equal(task.s["meas"], task._measure(task._all_rows))
        np.testing.assert_array_equal(task._stiffness(), task.model.stiffness(task.s["x"]))
    p, m, c = task.params, task.s["meas"], task._cols()
    q1 = pivot_position(p.pivot, m[:, 0] / c["n1"])
    q2 = m[:, 1] / c["ratio"]
    K_s = spring_stiffness(p.lever, q1, m[:, 2] - q2)
    K = np.where(K_s > 0, np.maximum(K_s * c["K_b"] / (K_s + c["K_b"]), 0.1), 0.1)
    util = np.minimum(task.s["i2t"] / c["i2t_lim"], 1.0)
    expect = np.stack([q1, q2, m[:, 2], *task.s["vel"].T, *task.s["cur"].T, np.log(K), *util.T], axis=1)
    np.testing.assert_array_equal(task._common_obs(task._all_rows), expect)
    venv.close()


@pytest.mark.parametrize("env_id", ["vsa_gym/VsaUT2-PositionStiffness-v0", "vsa_gym/VsaUT2-Throw-v0"])
def test_vsaut2_i2t_utilisation_is_observed_and_reaches_one_at_the_trip(env_id: str) -> None:
    """The observed I^2 t channels are the drives' heating states over the trip threshold: they grow under
    a held peak current, and the episode ends on the trip exactly when the frame drive's channel reaches 1."""
    env = gym.make(env_id, control_mode="current", i2t_trip_s=0.05, i2t_foldback=None)  # the trip itself
    task = env.unwrapped.task
    names = [ch.name for ch in task.obs_channels]
    k1, k2 = names.index("i2t_1"), names.index("i2t_2")
    obs, _ = env.reset(seed=0)
    assert obs[k1] == 0.0 and obs[k2] == 0.0
    lim = task._cols()["i2t_lim"][0]
    seen = []
    for _ in range(200):
        # the frame drive at +-peak current, alternating so the output stays inside its stops
        obs, _, term, trunc, info = env.step(np.array([0.0, 1.0 if len(seen) % 20 < 10 else -1.0]))
        seen.append(obs[k2])
        np.testing.assert_allclose([obs[k1], obs[k2]], np.minimum(task.s["i2t"][0] / lim, 1.0), rtol=1e-6)
        if term or trunc:
            break
    assert term and info["margin_i2t"] <= 0.0 and seen[-1] == pytest.approx(1.0)
    assert np.all(np.diff(seen[: len(seen) // 2]) >= 0) and 0.0 < seen[len(seen) // 2] < 1.0


def _force_frame_stop(env: gym.Env, seed: int) -> tuple[int, dict]:
    """Drive the frame against its end stop at full voltage; returns (steps taken, info of the failing step)."""
    env.reset(seed=seed)
    for k in range(1, 5000):
        _, _, term, trunc, info = env.step(np.array([0.0, 1.0]))
        assert not trunc, "the frame stop was not reached before the time limit"
        if term:
            return k, info
    raise AssertionError("no failure")


def test_vsaut2_failure_charges_the_remaining_steps() -> None:
    """The failure term is -(failure_penalty + failure_rate * steps left to episode_steps), the default rate bounds
    the cost of every step before a failure (a failure is never cheaper than finishing), and the native vector
    env takes its time limit as the horizon."""
    env = gym.make("vsa_gym/VsaUT2-PositionStiffness-v0")
    task = env.unwrapped.task
    assert task.episode_steps == env.spec.max_episode_steps == 2500
    rate = float(task.failure_rate()[0])
    k, info = _force_frame_stop(env, 3)
    assert info["margin_frame_stop"] <= 0.0
    assert info["reward_failure"] == pytest.approx(-(100.0 + rate * (2500 - k)), rel=1e-12)
    # a second episode in the same env counts its steps from its own reset
    k2, info2 = _force_frame_stop(env, 4)
    assert info2["reward_failure"] == pytest.approx(-(100.0 + rate * (2500 - k2)), rel=1e-12)
    # explicit rate and horizon
    env3 = gym.make("vsa_gym/VsaUT2-PositionStiffness-v0", failure_rate=2.0, episode_steps=300, failure_penalty=5.0)
    k3, info3 = _force_frame_stop(env3, 3)
    assert k3 == k and info3["reward_failure"] == pytest.approx(-(5.0 + 2.0 * (300 - k3)), rel=1e-12)
    # the default rate exceeds the cost of any step that did not fail (random and bang-bang actions)
    worst = 0.0
    for seed in range(3):
        env.reset(seed=seed)
        for a in _actions("vsa_gym/VsaUT2-PositionStiffness-v0", 1500, seed=seed):
            a = np.sign(a) if seed == 2 else a
            _, r, term, trunc, info = env.step(a)
            if term or trunc:
                break
            worst = max(worst, -r)
    assert 0.0 < worst < rate
    venv = gym.make_vec("vsa_gym/VsaUT2-PositionStiffness-v0", num_envs=2, vectorization_mode="vector_entry_point",
                        max_episode_steps=700)
    assert venv.unwrapped.task.episode_steps == 700
    with pytest.raises(ValueError, match="episode_steps"):
        gym.make("vsa_gym/VsaUT2-PositionStiffness-v0", episode_steps=0)
    with pytest.raises(ValueError, match="failure_rate"):
        gym.make("vsa_gym/VsaUT2-PositionStiffness-v0", failure_rate=-1.0)


@pytest.mark.parametrize("env_id, rate", [("vsa_gym/ELPAS-QuarterCar-v0", 1.0),
                                          ("vsa_gym/ELPAS-ForceTracking-v0", 2.0)])
def test_elpas_failure_charges_the_remaining_steps(env_id: str, rate: float) -> None:
    """With failure_rate an eLPAS failure costs failure_penalty + failure_rate per step left, so ending the episode
    on a constraint on purpose scores below the zero action (on the quarter car, with the fixed penalty alone, a
    trained agent's did score above the skyhook); the default (0) is the fixed penalty.  The drive's software travel
    limit is off here (``soft_limit=None``), so that full voltage reaches the end stop."""
    off = {"soft_limit": None}
    env = gym.make(env_id, failure_rate=rate, **off)
    assert env.unwrapped.task.episode_steps == env.spec.max_episode_steps == 5000

    def crash(e: gym.Env) -> tuple[float, int, dict]:
        e.reset(seed=1)
        ret, k = 0.0, 0
        while True:  # full voltage: the cone turns into its gamma end stop
            _, r, term, trunc, info = e.step(np.array([1.0], dtype=np.float32))
            ret, k = ret + r, k + 1
            assert not trunc
            if term:
                return ret, k, info

    ret, k, info = crash(env)
    assert info["margin_gamma_stop"] <= 0.0
    assert info["reward_failure"] == pytest.approx(-(100.0 + rate * (5000 - k)), rel=1e-12)
    env.reset(seed=1)
    zero = 0.0
    for _ in range(5000):  # zero voltage: the shorted motor holds the cone
        _, r, term, _, _ = env.step(np.array([0.0], dtype=np.float32))
        zero += r
        assert not term
    assert ret < zero
    _, k0, info0 = crash(gym.make(env_id, **off))
    assert k0 == k and info0["reward_failure"] == -100.0  # the default: the fixed penalty
    _, k2, info2 = crash(gym.make(env_id, failure_rate=0.5, episode_steps=900, failure_penalty=5.0, **off))
    assert k2 == k and info2["reward_failure"] == pytest.approx(-(5.0 + 0.5 * (900 - k2)), rel=1e-12)
    venv = gym.make_vec(env_id, num_envs=2, vectorization_mode="vector_entry_point", max_episode_steps=700)
    assert venv.unwrapped.task.episode_steps == 700
    with pytest.raises(ValueError, match="failure_rate"):
        gym.make(env_id, failure_rate=float("nan"))
    with pytest.raises(ValueError, match="episode_steps"):
        gym.make(env_id, episode_steps=0)


def test_quarter_car_wk_filter_step_equals_scipy_sosfilt() -> None:
    """The compiled one-sample W_k filter of the quarter-car task is scipy.signal.sosfilt's recursion, bit for bit."""
    from scipy import signal

    from vsa_gym.devices.elpas.env_quarter_car import sos_step
    from vsa_gym.vehicle.comfort import wk_sos

    sos = wk_sos(1000.0)
    x = np.random.default_rng(0).normal(0.0, 3.0, (3, 300))
    zi_ref = np.zeros((sos.shape[0], 3, 2))
    zi = np.zeros((3, sos.shape[0], 2))
    for k in range(x.shape[1]):
        y_ref, zi_ref = signal.sosfilt(sos, x[:, k:k + 1], axis=1, zi=zi_ref)
        np.testing.assert_array_equal(sos_step(sos, x[:, k].copy(), zi), y_ref[:, 0])
    np.testing.assert_array_equal(zi, np.moveaxis(zi_ref, 0, 1))


def test_arm_hysteresis_state_column_in_the_elpas_envs() -> None:
    """eLPAS arm hysteresis on (params, or randomised over its switch ``effects.M_h``): the env's core state has the
    hysteresis column and each env step is the core's own step (``model.step_rig``, bit for bit); rows drawn with
    ``M_h = 0`` keep it at exactly 0; a vector env equals single envs."""
    from vsa_gym.devices.elpas import model as em
    from vsa_gym.devices.elpas.params import ElpasEffects, ElpasParams

    env = gym.make("vsa_gym/ELPAS-ForceTracking-v0", params=ElpasParams(effects=ElpasEffects(M_h=20.0)))
    env.reset(seed=0)
    task = env.unwrapped.task
    assert task.s["x"].shape == (1, em.N_RIG + 1)
    for a in _actions("vsa_gym/ELPAS-ForceTracking-v0", 60, seed=2):
        x0 = task.s["x"].copy()
        _, _, _, _, info = env.step(a)
        u = float(np.clip(a, -1, 1)[0]) * float(task.params.motor.U_max)
        x1, e = em.step_rig(task.params, x0, np.array([[u, task.s["x"][0, em.ALPHA]]]))
        np.testing.assert_array_equal(task.s["x"], x1)
        assert info["energy_el"] == e[0, em.P_EL]
    assert 0.0 < abs(task.s["x"][0, em.N_RIG]) <= 20.0
    _check_randomised_effect_column("vsa_gym/ELPAS-QuarterCar-v0", (0.0, 30.0), column=em.N_VEHICLE)
