"""vsa-gym: simulations, Gymnasium environments, baselines and identification for the vsaUT-II and the eLPAS."""

__version__ = "0.1.0"

from vsa_gym.envs import register_envs as _register_envs  # noqa: E402  (registers the Gymnasium ids)

_register_envs()
