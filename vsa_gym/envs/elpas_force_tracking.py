"""Moved to :mod:`vsa_gym.devices.elpas.env_force_tracking`.

This import path is kept for compatibility: it is the same module object."""

import sys

from vsa_gym.devices.elpas import env_force_tracking as _moved

sys.modules[__name__] = _moved
