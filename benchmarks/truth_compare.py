"""Two runs of the truth case sets side by side: which cases changed, and whether a change of time is the code's.

    python -m benchmarks.truth_compare OLD_DIR NEW_DIR      # OUT folders of benchmarks.identify_truth

Prints the cases (matched by case seed) whose named effects or recovery differ, the cases present in only one
run, and the per-case time ratio new / old: its median over all matched cases, over the cases that fitted more
candidates in the new run (work the change added) and over the others.  Where the others slowed by the same
factor as the whole, the difference is the machine's load beside the runs, not the change.
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


def compare(old: dict[int, dict[str, Any]], new: dict[int, dict[str, Any]]) -> list[str]:
    """Report lines for two runs' cases (by case seed)."""
    both = sorted(set(old) & set(new))
    lines = [f"{len(both)} cases in both runs; only in the old run: {sorted(set(old) - set(new)) or 'none'}; "
             f"only in the new run: {sorted(set(new) - set(old)) or 'none'}"]
    changed = [s for s in both if (old[s]["named"], old[s]["recovered"]) != (new[s]["named"], new[s]["recovered"])]
    lines.append(f"cases whose named effects or recovery changed: {len(changed)}")
    for s in changed:
        lines.append(f"  {s} planted {'+'.join(old[s]['effects']) or 'nothing'}: named "
                     f"{'+'.join(old[s]['named']) or 'nothing'} (recovered {old[s]['recovered']}) -> "
                     f"{'+'.join(new[s]['named']) or 'nothing'} (recovered {new[s]['recovered']})")
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
    ap.add_argument("old", help="OUT folder of the earlier run (its results.json)")
    ap.add_argument("new", help="OUT folder of the later run")
    args = ap.parse_args(argv)
    print("\n".join(compare(_cases(args.old), _cases(args.new))))
    return 0


if __name__ == "__main__":
    sys.exit(main())
