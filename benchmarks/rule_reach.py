"""Which stored cases can a selection rule reach?  The scans behind the re-runs in docs/identification.md.

    python -m benchmarks.rule_reach OUT_DIR [OUT_DIR ...] --rule polish|low-rank
        # OUT folders of benchmarks.identify_truth

``--rule polish`` (tenth session; ``Identifier._forward``: where no newcomer passes in a later round, the accepted
effects take the best joint fit's values if they validate as well without the newcomer) can only change a case
with a later round, in some replay and branch, in which no candidate passed and the best fitted candidate
validated better than the model before that round.  The model before is read as the best passing candidate of
the round before in the same replay and branch (round one's runner-up itself, for the first round of its branch);
a swap or a refit after it only lowers that error, so the list errs on the side of too many cases.

``--rule low-rank`` (ninth session: where nothing passes in round one on a misfit above 3x the noise floor, the
candidates ranked too low to fit are fitted too) can only change a case in which round one of the full replay or
of the shooting windows had no candidate that passed.  The nominal misfit is not stored, so this also lists
cases the rule leaves alone (a misfit within 3x the floor).

``--rule emf-share`` (twentieth session: ``DriveAdapter.restarts`` also refits a mesh loss with all of ``b`` as
back-EMF) can only change a case whose record leaves the back-EMF share free (a voltage input with a lag, a
sidecar that does not give ``b_emf``): the record is drawn again from the case's seed and its adapter asked.  The
list is every such case, whether or not a mesh loss was ranked or fitted in it.

``--rule sticking-restart`` (twenty-seventh session: the refined refit restarts a friction selected sticking
sticking, ``vsa_gym.identify.starts.restart_base``) can only change a case whose replay was refitted at finer
substeps (its replay line says "refitted at") and whose fitted model has a friction that sticks (a ``sticks``
switch on).

Prints, per folder, the case seeds to give ``benchmarks.identify_truth --redo``.
"""

from __future__ import annotations

import argparse
import json
import math
import re
import sys
import tempfile
from pathlib import Path
from typing import Any

from benchmarks.truth_compare import bare, phase
from tests.truthsim.scenarios import draw_case, write_case
from vsa_gym.devices.drive.adapter import EMF_SHARE
from vsa_gym.identify.adapters import make_adapter
from vsa_gym.identify.record import load_record

BRANCH = re.compile(r"from runner-up (\w+): $")


def _passing(cands: list[dict[str, Any]]) -> list[float]:
    return [c["val_score"] for c in cands if bare(c["reason"]).startswith("passes") and _finite(c)]


def _finite(c: dict[str, Any]) -> bool:
    v = c.get("val_score")
    return v is not None and math.isfinite(v)


def reachable(case: dict[str, Any]) -> bool:
    """Whether ``case`` has a later round without a passer whose best fit validated better than the model before."""
    groups: dict[tuple[str, int], list[dict[str, Any]]] = {}
    for c in case["candidates"]:
        groups.setdefault((phase(c["reason"]), c["round"]), []).append(c)
    for (ph, rnd), cands in groups.items():
        fitted = [c["val_score"] for c in cands if _finite(c)]
        if rnd < 2 or not fitted or _passing(cands):
            continue
        branch = BRANCH.search(ph)
        if branch and rnd == 2:  # the branch starts from round one's runner-up, fitted alone in the main line
            line = ph[:branch.start()]
            before = [c["val_score"] for c in groups.get((line, 1), []) if c["name"] == branch.group(1) and _finite(c)]
        else:
            before = _passing(groups.get((ph, rnd - 1), []))
        if before and min(fitted) < max(before):
            return True
    return False


def round_one_without_passer(case: dict[str, Any]) -> bool:
    """Whether round one of the full replay or of the shooting windows of ``case`` had no candidate that passed."""
    lines: dict[str, list[dict[str, Any]]] = {}
    for c in case["candidates"]:
        if c["round"] == 1 and not BRANCH.search(phase(c["reason"])):
            lines.setdefault(phase(c["reason"]), []).append(c)
    return any(not any(c["accepted"] or bare(c["reason"]).startswith("passes") for c in cands)
               for cands in lines.values())


def emf_share_free(case: dict[str, Any]) -> bool:
    """Whether the record of ``case``, drawn again from its seed, leaves the back-EMF share of ``b`` free."""
    drawn = draw_case(case["seed"], tuple(case["effects"]), rate=case.get("rate"), duration=case.get("duration"))
    with tempfile.TemporaryDirectory(prefix="rule_reach_") as tmp:
        return EMF_SHARE in make_adapter(load_record(write_case(drawn, tmp))).free


def refined_sticking(case: dict[str, Any]) -> bool:
    """Whether ``case`` was refitted at finer substeps with a friction that sticks in its fitted model."""
    return ("refitted at" in (case.get("replay") or "")
            and any(v.get("sticks", 0.0) == 1.0 for v in (case.get("fitted") or {}).values()))


#: rules decided from the record alone (a case spec of ``benchmarks.identify_truth`` is enough): its ``--reach``
SPEC_RULES = {"emf-share": emf_share_free}
RULES = {"polish": reachable, "low-rank": round_one_without_passer, "sticking-restart": refined_sticking,
         **SPEC_RULES}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dirs", nargs="+", help="OUT folders of benchmarks.identify_truth")
    ap.add_argument("--rule", choices=sorted(RULES), required=True, help="the selection rule (see the module)")
    args = ap.parse_args(argv)
    can_reach = RULES[args.rule]
    total = 0
    for d in args.dirs:
        seeds = [c["seed"] for c in json.loads((Path(d) / "results.json").read_text())["cases"] if can_reach(c)]
        total += len(seeds)
        print(f"{d}: {len(seeds)} {' '.join(map(str, seeds))}")
    print(f"{total} cases in {len(args.dirs)} folders")
    return 0


if __name__ == "__main__":
    sys.exit(main())
