"""Moved to :mod:`vsa_gym.devices.elpas.current_loop`.

This import path is kept for compatibility: it is the same module object."""

import sys

from vsa_gym.devices.elpas import current_loop as _moved

sys.modules[__name__] = _moved
