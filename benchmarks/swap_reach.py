"""How far apart, alone, were the look-alikes that replaced an earlier effect?  The evidence behind
:data:`vsa_gym.identify.pipeline.SWAP_REACH`.

    python -m benchmarks.swap_reach OUT_DIR [OUT_DIR ...]      # OUT folders of benchmarks.identify_truth

For every replacement the selection made (a candidate whose reason reads "replaces OLD beside NEWEST", accepted
or later superseded, in any branch), prints the validation error each of the two had when round one fitted it
alone in the same replay (full record or shooting windows), their ratio and whether the replacement is in the
case's final selection ("kept") or was superseded (a runner-up branch not adopted, a later choice), then the
largest ratio of all and of those kept.  A look-alike that round one did not fit is listed as "not fitted".
"""

from __future__ import annotations

import argparse
import json
import math
import re
import sys
from pathlib import Path
from typing import Any

from benchmarks.truth_compare import WINDOWS, phase

REPLACES = re.compile(r"replaces (\w+) beside (\w+)")


def replacements(case: dict[str, Any]) -> list[tuple[str, str, float, float, bool]]:
    """``(old, new, old's round-one validation, new's, kept)`` for each replacement in a case (NaN: not fitted;
    ``kept``: the replacement is in the case's final selection)."""
    out = []
    cands = case["candidates"]
    for i, c in enumerate(cands):
        m = REPLACES.search(c["reason"])
        if not m:
            continue
        main_line = WINDOWS if c["reason"].startswith(WINDOWS) else ""  # round one of the same replay, no branch
        alone = {k["name"]: k["val_score"] for k in cands[:i]
                 if k["round"] == 1 and phase(k["reason"]) == main_line and k.get("val_score") is not None}
        old, new = m.group(1), c["name"]
        out.append((old, new, float(alone.get(old, math.nan)), float(alone.get(new, math.nan)), bool(c["accepted"])))
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dirs", nargs="+", help="OUT folders of benchmarks.identify_truth")
    args = ap.parse_args(argv)
    ratios: list[tuple[float, bool]] = []
    for d in args.dirs:
        for case in json.loads((Path(d) / "results.json").read_text())["cases"]:
            for old, new, s_old, s_new, kept in replacements(case):
                ratio = s_new / s_old if s_old > 0 else math.nan
                seen = f"{s_new:.3g}" if math.isfinite(s_new) else "not fitted"
                print(f"{case['seed']:6d} {'+'.join(case['effects']) or 'control':45s} {old} -> {new}: alone "
                      f"{s_old:.3g} vs {seen} ({ratio:.2f}x){'  kept' if kept else '  superseded'}"
                      f"{'' if case.get('recovered') else ', case missed'}")
                ratios.append((ratio, kept))
    for label, rs in (("all", [r for r, _ in ratios]), ("kept in the final selection", [r for r, k in ratios if k])):
        finite = [r for r in rs if math.isfinite(r)]
        print(f"{label}: {len(rs)} replacements, {len(rs) - len(finite)} of a look-alike round one did not fit"
              + (f", largest ratio {max(finite):.2f}x" if finite else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())
