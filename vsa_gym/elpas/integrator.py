"""Moved to :mod:`vsa_gym.devices.elpas.integrator`.

This import path is kept for compatibility: it is the same module object."""

import sys

from vsa_gym.devices.elpas import integrator as _moved

sys.modules[__name__] = _moved
