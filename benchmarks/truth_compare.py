"""Two runs of the truth case sets side by side: which cases changed, and whether a change of time is the code's.

    python -m benchmarks.truth_compare OLD_DIR NEW_DIR [OLD_DIR NEW_DIR ...]   # OUT folders of identify_truth

Prints the cases (matched by case seed) whose named effects or recovery differ, those that name the same but
whose fitted values differ (with the largest relative change of a value), the cases present in only one run,
the cases whose time differs (the ones redone, where NEW is a copy of OLD re-run with ``identify_truth --redo``)
with their summed seconds, and the per-case time ratio new / old: its median over all matched cases, over the
cases that fitted more candidates in the new run (work the change added) and over the others.  Where the others
slowed by the same factor as the whole, the difference is the machine's load beside the runs, not the change.
Several pairs of folders are compared pair by pair, then totalled.
"""

from __future__ import annotations

import argparse
import json
import math
import re
import sys
from pathlib import Path
from typing import Any

#: what a candidate's reason says before its own words: the selection on shooting windows ran it, or the branch
#: from round one's runner-up did (``Identifier._second_opinion``, ``Identifier._runner_up``)
WINDOWS = "on shooting windows: "
PREFIX = re.compile(r"^(on shooting windows: )?(from runner-up \w+: )?")


def phase(reason: str) -> str:
    """The replay and branch a candidate belongs to: its reason's prefix (empty: the full replay's main line)."""
    m = PREFIX.match(reason)
    return m.group(0) if m else ""


def bare(reason: str) -> str:
    """A candidate's reason without the prefix of :func:`phase`."""
    return reason[len(phase(reason)):]


def _cases(folder: str) -> dict[int, dict[str, Any]]:
    return {c["seed"]: c for c in json.loads((Path(folder) / "results.json").read_text())["cases"]}


def fitted_candidates(case: dict[str, Any]) -> int:
    """How many candidates were fitted (a candidate that was not fitted has no validation score)."""
    return sum(1 for k in case["candidates"] if k.get("val_score") is not None and not math.isnan(k["val_score"]))


def _median(xs: list[float]) -> float:
    s = sorted(xs)
    n = len(s)
    return float("nan") if n == 0 else (s[n // 2] if n % 2 else 0.5 * (s[n // 2 - 1] + s[n // 2]))


def largest_change(old: dict[str, dict[str, float]], new: dict[str, dict[str, float]]) -> tuple[float, str]:
    """The largest relative change of a fitted value between two cases' ``fitted`` dicts, and its key (the
    friction switch left out: one friction's ``sticks`` may sit on either of its terms)."""
    best = (0.0, "")
    for effect in set(old) & set(new):
        for key in set(old[effect]) & set(new[effect]) - {"sticks"}:
            a, b = old[effect][key], new[effect][key]
            change = abs(b - a) / max(abs(a), 1e-300)
            if change > best[0]:
                best = (change, f"{effect}.{key}")
    return best


def tally(old: dict[int, dict[str, Any]], new: dict[int, dict[str, Any]]) -> dict[str, Any]:
    """Of the cases in both runs: ``changed`` (named effects or recovery), ``moved`` (the same, other fitted
    values: seed -> :func:`largest_change`), ``redone`` (their time differs) and the redone cases' summed
    ``seconds`` (old, new)."""
    both = sorted(set(old) & set(new))
    changed = [s for s in both if (old[s]["named"], old[s]["recovered"]) != (new[s]["named"], new[s]["recovered"])]
    moved = {s: largest_change(old[s].get("fitted") or {}, new[s].get("fitted") or {}) for s in both
             if s not in changed and old[s].get("fitted") != new[s].get("fitted")}
    redone = [s for s in both if old[s]["seconds"] != new[s]["seconds"]]
    return {"both": both, "changed": changed, "moved": moved, "redone": redone,
            "seconds": (sum(old[s]["seconds"] for s in redone), sum(new[s]["seconds"] for s in redone))}


def compare(old: dict[int, dict[str, Any]], new: dict[int, dict[str, Any]]) -> list[str]:
    """Report lines for two runs' cases (by case seed)."""
    t = tally(old, new)
    both, changed = t["both"], t["changed"]
    lines = [f"{len(both)} cases in both runs; only in the old run: {sorted(set(old) - set(new)) or 'none'}; "
             f"only in the new run: {sorted(set(new) - set(old)) or 'none'}"]
    lines.append(f"cases whose named effects or recovery changed: {len(changed)}")
    for s in changed:
        lines.append(f"  {s} planted {'+'.join(old[s]['effects']) or 'nothing'}: named "
                     f"{'+'.join(old[s]['named']) or 'nothing'} (recovered {old[s]['recovered']}) -> "
                     f"{'+'.join(new[s]['named']) or 'nothing'} (recovered {new[s]['recovered']})")
    lines.append(f"the same named effects and recovery, fitted values differ: {len(t['moved'])}")
    lines += [f"  {s}: largest relative change {c:.2g} ({key})" for s, (c, key) in t["moved"].items()]
    lines.append(f"cases whose time differs (redone): {len(t['redone'])}, {t['seconds'][0]:.1f} s before, "
                 f"{t['seconds'][1]:.1f} s after")
    more = [s for s in both if fitted_candidates(new[s]) > fitted_candidates(old[s])]
    ratio = {s: new[s]["seconds"] / old[s]["seconds"] for s in both if old[s]["seconds"] > 0}
    rest = [s for s in ratio if s not in more]
    lines.append(f"time new / old per case, median: all {_median(list(ratio.values())):.2f}; the {len(more)} cases "
                 f"that fitted more candidates {_median([ratio[s] for s in more if s in ratio]):.2f}; the other "
                 f"{len(rest)} {_median([ratio[s] for s in rest]):.2f}")
    if more:
        lines.append(f"cases that fitted more candidates: {', '.join(map(str, more))}")
    return lines


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dirs", nargs="+", metavar="OLD NEW",
                    help="pairs of OUT folders: the earlier run (its results.json), then the later")
    args = ap.parse_args(argv)
    if len(args.dirs) % 2:
        ap.error(f"folders come in pairs (old, new); got {len(args.dirs)}")
    pairs = list(zip(args.dirs[::2], args.dirs[1::2], strict=True))
    totals = {"changed": 0, "moved": 0, "redone": 0, "old": 0.0, "new": 0.0}
    for old_dir, new_dir in pairs:
        old, new = _cases(old_dir), _cases(new_dir)
        if len(pairs) > 1:
            print(f"{old_dir} -> {new_dir}")
        print("\n".join(compare(old, new)))
        t = tally(old, new)
        for key in ("changed", "moved", "redone"):
            totals[key] += len(t[key])
        totals["old"] += t["seconds"][0]
        totals["new"] += t["seconds"][1]
    if len(pairs) > 1:
        print(f"all {len(pairs)} pairs: named effects or recovery changed in {totals['changed']}, fitted values "
              f"differ in {totals['moved']} more; {totals['redone']} cases redone, {totals['old']:.1f} s before, "
              f"{totals['new']:.1f} s after")
    return 0


if __name__ == "__main__":
    sys.exit(main())
