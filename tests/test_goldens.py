"""Every golden group recomputed equals its stored copy to 1e-12, ``identify`` to 1e-8 (tests/goldens/record.py says
what they cover and why ``identify`` has its own tolerance).

A change that is meant to alter results re-records them (``python -m tests.goldens.record --write GROUP``) and
says so in its commit; any other difference is a regression.
"""

from __future__ import annotations

import pytest

from tests.goldens import record


@pytest.mark.parametrize("group", list(record.GROUPS))
def test_golden_outputs_are_unchanged(group: str) -> None:
    bad = record.compare(record.GROUPS[group](), record.load(group), record.TOLERANCE.get(group, 1e-12))
    assert not bad, f"{len(bad)} differences in {group}:\n" + "\n".join(bad[:30])
