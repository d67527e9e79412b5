"""Moved to :mod:`vsa_gym.devices.vsaut2.pivot`.

This import path is kept for compatibility: it is the same module object."""

import sys

from vsa_gym.devices.vsaut2 import pivot as _moved

sys.modules[__name__] = _moved
