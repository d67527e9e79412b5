"""The ``vsa-gym`` command line.

Sub-commands:

* ``vsa-gym reproduce {vsaut2,elpas,all} [--out DIR]`` -- regenerate the papers' figures,
  a markdown report and ``summary.json`` per device.
* ``vsa-gym datasheet vsaut2 [--json FILE]`` -- Table IV of the vsaUT-II from the model.
* ``vsa-gym data check FILE`` -- validate a measured record (CSV/Parquet + JSON sidecar,
  ``docs/measured-data.md``); lists every problem and exits non-zero on any.
* ``vsa-gym identify DATA [--json FILE] [--out DIR]`` -- replay, diagnose and select model
  effects for a record (a path, or a shipped name such as ``emps``; ``docs/identification.md``).

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

from vsa_gym.devices import device, devices

#: devices with a paper reproduction / a datasheet (:mod:`vsa_gym.devices`)
DEVICES: tuple[str, ...] = tuple(d.name for d in devices() if d.reproduce)
DATASHEETS: tuple[str, ...] = tuple(d.name for d in devices() if d.datasheet)


def _reproduce(args: argparse.Namespace) -> int:
    devices = DEVICES if args.device == "all" else (args.device,)
    out_root = Path(args.out)
    for dev in devices:
        out = out_root / dev if args.device == "all" else out_root
        out.mkdir(parents=True, exist_ok=True)
        t0 = time.perf_counter()
        module = importlib.import_module(str(device(dev).reproduce))
        summary = module.run(out)
        (out / "summary.json").write_text(json.dumps(summary, indent=2, sort_keys=True) + "\n")
        print(f"[{dev}] wrote {out} in {time.perf_counter() - t0:.1f} s")
        for key, value in sorted(summary.items()):
            print(f"  {key}: {value:.6g}" if isinstance(value, float) else f"  {key}: {value}")
    return 0


def _datasheet(args: argparse.Namespace) -> int:
    module = importlib.import_module(str(device(args.device).datasheet))
    rows = module.compute()
    print(module.format_table(rows))
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=2) + "\n")
        print(f"wrote {args.json}")
    return 0


def _data_check(args: argparse.Namespace) -> int:
    from vsa_gym.identify.record import check_record, resolve

    status = 0
    for item in args.files:
        path, _ = resolve(item)
        problems = check_record(path)
        if problems:
            status = 1
            print(f"{path}: {len(problems)} problem(s)")
            for p in problems:
                print(f"  - {p}")
        else:
            print(f"{path}: ok")
    return status


def _identify(args: argparse.Namespace) -> int:
    from vsa_gym.identify.pipeline import identify
    from vsa_gym.identify.record import RecordError

    t0 = time.perf_counter()
    try:
        result = identify(args.data, max_effects=args.max_effects, replay=args.replay)
    except (RecordError, ValueError, FileNotFoundError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print("\n".join(result.statements()))
    print(f"\nreplay: {result.replay_mode}")
    print(f"held-out: {result.test_name}")
    print(result.to_frame().to_string(index=False))
    if args.json:
        result.to_json(args.json)
        print(f"wrote {args.json}")
    if args.out:
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        result.to_json(out / "identification.json")
        (out / "report.md").write_text(result.report_markdown())
        files = result.plot(out)
        print(f"wrote {out}/identification.json, report.md, " + ", ".join(f.name for f in files))
    print(f"[{time.perf_counter() - t0:.1f} s]")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="vsa-gym", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("reproduce", help="regenerate a paper's figures, report and summary.json")
    p.add_argument("device", choices=(*DEVICES, "all"))
    p.add_argument("--out", default="out/reproduce", help="output folder (default: out/reproduce)")
    p.set_defaults(func=_reproduce)

    p = sub.add_parser("datasheet", help="compute a device datasheet from the model")
    p.add_argument("device", choices=DATASHEETS)
    p.add_argument("--json", default=None, help="also write the rows as JSON to this file")
    p.set_defaults(func=_datasheet)

    p = sub.add_parser("data", help="measured-data tools")
    dsub = p.add_subparsers(dest="data_command", required=True)
    q = dsub.add_parser("check", help="validate measured records; exits non-zero on any problem")
    q.add_argument("files", nargs="+", help="CSV/Parquet files with a JSON sidecar, or shipped record names")
    q.set_defaults(func=_data_check)

    p = sub.add_parser("identify", help="replay, diagnose and select model effects for a measured record")
    p.add_argument("data", help="record path or shipped name (emps, emps-train, ced-1, ced-2)")
    p.add_argument("--json", default=None, help="write effects and before/after metrics as JSON")
    p.add_argument("--out", default=None, help="folder for the report, JSON and plots")
    p.add_argument("--max-effects", type=int, default=2, help="most effects to accept (default 2)")
    p.add_argument("--replay", choices=("open_loop", "closed_loop"), default=None,
                   help="override the sidecar's replay mode")
    p.set_defaults(func=_identify)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    return int(args.func(args))


if __name__ == "__main__":
    sys.exit(main())
