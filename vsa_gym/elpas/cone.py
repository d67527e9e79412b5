"""Moved to :mod:`vsa_gym.devices.elpas.cone`.

This import path is kept for compatibility: it is the same module object."""

import sys

from vsa_gym.devices.elpas import cone as _moved

sys.modules[__name__] = _moved
