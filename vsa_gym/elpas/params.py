"""Moved to :mod:`vsa_gym.devices.elpas.params`.

This import path is kept for compatibility: it is the same module object."""

import sys

from vsa_gym.devices.elpas import params as _moved

sys.modules[__name__] = _moved
