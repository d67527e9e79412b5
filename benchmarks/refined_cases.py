"""Which cases of stored truth-set runs a change of the refined refit can reach, and what redoing them changed.

    python -m benchmarks.refined_cases DIR [DIR ...] [--sticking]           # list, with a --redo command per folder
    python -m benchmarks.refined_cases DIR [DIR ...] --against PREFIX_OLD PREFIX_NEW

``DIR`` are OUT folders of :mod:`benchmarks.identify_truth`.  A case is *refined* where its replay was refitted at
finer substeps (the report's replay line says "refitted at", :func:`vsa_gym.identify.convergence.refined`); with
``--sticking``, only those whose fitted model has a friction that sticks (a ``sticks`` switch on), the cases that
:func:`vsa_gym.identify.starts.restart_base` acts on.  Each folder's list comes with the ``--redo`` command line
that re-runs just those cases (its set arguments read from the folder name: ``*_pS`` a pairs set, ``*_tS`` the
timing set, else a full set).

With ``--against OLD NEW`` each ``DIR`` names a folder by its suffix after the prefix (``rel_s97`` with ``rel_``
gives ``s97``); the redone cases (their time differs between ``OLD + suffix`` and ``NEW + suffix``) are compared:
how many, their summed seconds before and after, the cases whose named effects or recovery changed, and those
whose fitted values differ (with the largest relative change of a value; the friction switch left out).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any


def _cases(folder: str | Path) -> list[dict[str, Any]]:
    return json.loads((Path(folder) / "results.json").read_text())["cases"]


def reached(case: dict[str, Any], sticking: bool) -> bool:
    """Whether ``case`` was refined (and, with ``sticking``, fitted a friction that sticks)."""
    if "refitted at" not in (case.get("replay") or ""):
        return False
    return not sticking or any(v.get("sticks", 0.0) == 1.0 for v in (case.get("fitted") or {}).values())


def _largest_change(old: dict[str, dict[str, float]], new: dict[str, dict[str, float]]) -> tuple[float, str]:
    """The largest relative change of a fitted value between two cases' ``fitted`` dicts, and its key (a switch
    that moved from one effect to another counts as no change of value)."""
    best = (0.0, "")
    for effect in set(old) & set(new):
        for key in set(old[effect]) & set(new[effect]):
            if key == "sticks":
                continue
            a, b = old[effect][key], new[effect][key]
            change = abs(b - a) / max(abs(a), 1e-300)
            if change > best[0]:
                best = (change, f"{effect}.{key}")
    return best


def set_arguments(folder: str) -> str:
    """The ``identify_truth`` arguments of a set, from its folder name (``..._pS``, ``..._tS``, ``..._sS``)."""
    tag = Path(folder).name.rsplit("_", 1)[-1]
    seed = tag[1:]
    if tag.startswith("p"):
        return f"--jobs 2 --seed {seed} --draws 0 --pairs 24 --controls 0"
    if tag.startswith("t"):
        return f"--jobs 1 --seed {seed} --rate 1000 --duration 20"
    return f"--jobs 2 --seed {seed}"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dirs", nargs="+", help="OUT folders (with --against: their suffixes' folders under OLD)")
    ap.add_argument("--sticking", action="store_true", help="only refined cases with a friction that sticks")
    ap.add_argument("--against", nargs=2, metavar=("OLD", "NEW"), help="folder prefixes of the runs to compare")
    args = ap.parse_args(argv)
    if args.against is None:
        total = 0
        for folder in args.dirs:
            seeds = [c["seed"] for c in _cases(folder) if reached(c, args.sticking)]
            total += len(seeds)
            print(f"{folder}: {len(seeds)}")
            if seeds:
                print(f"  python -m benchmarks.identify_truth {set_arguments(folder)} --out NEW --redo "
                      + " ".join(map(str, seeds)))
        print(f"{total} cases")
        return 0
    old_prefix, new_prefix = args.against
    n, t_old, t_new, changed, moved = 0, 0.0, 0.0, [], []
    for folder in args.dirs:
        suffix = Path(folder).name[len(Path(old_prefix).name):]
        old = {c["seed"]: c for c in _cases(old_prefix + suffix)}
        for c in _cases(new_prefix + suffix):
            o = old.get(c["seed"])
            if o is None or c["seconds"] == o["seconds"]:
                continue  # not redone
            n += 1
            t_old, t_new = t_old + o["seconds"], t_new + c["seconds"]
            if c["named"] != o["named"] or c["recovered"] != o["recovered"]:
                changed.append(c["seed"])
            elif c["fitted"] != o["fitted"]:
                moved.append((c["seed"], _largest_change(o["fitted"], c["fitted"])))
    print(f"redone: {n} cases, {t_old:.1f} s before, {t_new:.1f} s after")
    print(f"named effects or recovery changed: {len(changed)} {changed}")
    print(f"the same named effects and recovery, fitted values differ: {len(moved)}"
          + "".join(f"\n  {seed}: largest relative change {change:.2g} ({key})" for seed, (change, key) in moved))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
