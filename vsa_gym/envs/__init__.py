"""Gymnasium environments of vsa-gym, registered in the ``vsa_gym`` namespace.

===================================  =====================================  ===========  ==========
id                                   task                                   control_dt   time limit
===================================  =====================================  ===========  ==========
``vsa_gym/VsaUT2-PositionStiffness-v0``  position + stiffness tracking, disturbance  2 ms   2500 steps (5 s)
``vsa_gym/VsaUT2-Throw-v0``              max output speed at release, energy budget  2 ms   500 steps (1 s)
``vsa_gym/ELPAS-ForceTracking-v0``       force tracking on the rig, imposed alpha    1 ms   5000 steps (5 s)
``vsa_gym/ELPAS-QuarterCar-v0``          ISO 2631 comfort on an ISO 8608 road        2 ms   5000 steps (10 s)
===================================  =====================================  ===========  ==========

Quick start::

    import gymnasium as gym
    import vsa_gym  # registers the ids
    from stable_baselines3 import PPO
    env = gym.make("vsa_gym/ELPAS-ForceTracking-v0")
    PPO("MlpPolicy", env).learn(100_000)

``gym.make_vec(id, num_envs=n)`` returns the native batched vector environment
(:mod:`vsa_gym.envs.vector`); :func:`vsa_gym.envs.sb3.make_sb3_vec_env` wraps it for SB3.
"""

from __future__ import annotations

import gymnasium as gym

from vsa_gym.devices import devices

#: every device's environments (:mod:`vsa_gym.devices`): name -> (entry-point prefix, time limit in steps)
ENV_SPECS: dict[str, tuple[str, int]] = {e.name: (e.entry, e.max_episode_steps) for d in devices() for e in d.envs}
ENV_IDS: tuple[str, ...] = tuple(f"vsa_gym/{name}" for name in ENV_SPECS)


def register_envs() -> None:
    """Register every id (idempotent)."""
    for name, (entry, steps) in ENV_SPECS.items():
        env_id = f"vsa_gym/{name}"
        if env_id in gym.registry:
            continue
        gym.register(id=env_id, entry_point=f"{entry}Env", vector_entry_point=f"{entry}VectorEnv",
                     max_episode_steps=steps)


register_envs()

__all__ = ["ENV_IDS", "register_envs"]
