"""The ``vsa-gym`` command line.

Sub-commands:

* ``vsa-gym reproduce {vsaut2,elpas,all} [--out DIR]`` -- regenerate the papers' figures,
  a markdown report and ``summary.json`` per device.
* ``vsa-gym datasheet vsaut2 [--json FILE]`` -- Table IV of the vsaUT-II from the model.

Each device package provides ``reproduce.run(out_dir) -> dict`` (the flat summary
map written to ``summary.json``); the CLI only dispatches, so the figure code
stays next to the physics it illustrates.
"""

from __future__ import annotations

import argparse
import importlib
import json
import sys
import time
from collections.abc import Sequence
from pathlib import Path

DEVICES = ("vsaut2", "elpas")


def _reproduce(args: argparse.Namespace) -> int:
    devices = DEVICES if args.device == "all" else (args.device,)
    out_root = Path(args.out)
    for dev in devices:
        out = out_root / dev if args.device == "all" else out_root
        out.mkdir(parents=True, exist_ok=True)
        t0 = time.perf_counter()
        module = importlib.import_module(f"vsa_gym.{dev}.reproduce")
        summary = module.run(out)
        (out / "summary.json").write_text(json.dumps(summary, indent=2, sort_keys=True) + "\n")
        print(f"[{dev}] wrote {out} in {time.perf_counter() - t0:.1f} s")
        for key, value in sorted(summary.items()):
            print(f"  {key}: {value:.6g}" if isinstance(value, float) else f"  {key}: {value}")
    return 0


def _datasheet(args: argparse.Namespace) -> int:
    module = importlib.import_module(f"vsa_gym.{args.device}.datasheet")
    rows = module.compute()
    print(module.format_table(rows))
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=2) + "\n")
        print(f"wrote {args.json}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="vsa-gym", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("reproduce", help="regenerate a paper's figures, report and summary.json")
    p.add_argument("device", choices=(*DEVICES, "all"))
    p.add_argument("--out", default="out/reproduce", help="output folder (default: out/reproduce)")
    p.set_defaults(func=_reproduce)

    p = sub.add_parser("datasheet", help="compute a device datasheet from the model")
    p.add_argument("device", choices=("vsaut2",))
    p.add_argument("--json", default=None, help="also write the rows as JSON to this file")
    p.set_defaults(func=_datasheet)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    return int(args.func(args))


if __name__ == "__main__":
    sys.exit(main())
