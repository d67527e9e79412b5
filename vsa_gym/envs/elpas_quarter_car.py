"""Moved to :mod:`vsa_gym.devices.elpas.env_quarter_car`.

This import path is kept for compatibility: it is the same module object."""

import sys

from vsa_gym.devices.elpas import env_quarter_car as _moved

sys.modules[__name__] = _moved
