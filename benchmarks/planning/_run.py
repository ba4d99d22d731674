"""The planning benchmark's command line."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

import msgspec

from benchmarks.common import format_table, machine_info
from benchmarks.planning._cases import ENGINES, QUICK_SIZES, SIZES, details, rows, run_case
from benchmarks.planning._execution import execute_all, executed_details, executed_rows
from benchmarks.planning._space import run_space, space_rows


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=sys.modules["benchmarks.planning"].__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--quick", action="store_true", help="2x4 and 3x8 only, 3 repetitions")
    parser.add_argument("--reps", type=int, default=0, help="repetitions per case (default 5)")
    parser.add_argument("--timeout", type=float, default=60.0, help="seconds per solve")
    parser.add_argument("--engines", default=",".join(ENGINES), help="comma-separated engines")
    parser.add_argument("--json", type=Path, help="also write every case as JSON")
    parser.add_argument(
        "--time-scale",
        type=float,
        default=0.01,
        metavar="S",
        help="executed plans: wall seconds per skill second (0: do not execute)",
    )
    args = parser.parse_args(argv)
    sizes = QUICK_SIZES if args.quick else SIZES
    reps = args.reps or (3 if args.quick else 7)
    engines: list[Any] = [e for e in args.engines.split(",") if e]
    info = machine_info(["unified_planning", "up_kairos", "kairos-planner", "up_fast_downward"])
    print(" ".join(f"{k}={v}" for k, v in info.items()), file=sys.stderr)
    cases = []
    for robots, parts in sizes:
        for goal in ("two", "all"):
            for engine in engines:
                print(f"{robots}x{parts} {goal} {engine} ...", file=sys.stderr, flush=True)
                cases.append(run_case(robots, parts, goal, engine, reps, args.timeout))
    space = []
    for goal in ("two", "all"):
        for engine in engines:
            robots, parts = sizes[-1]
            print(f"{robots}x{parts} {goal} {engine} shared space ...", file=sys.stderr, flush=True)
            space.append(run_space(robots, parts, goal, engine, reps, args.timeout))
    runs = args.reps or (3 if args.quick else 5)
    executed = execute_all(sizes, time_scale=args.time_scale, reps=runs) if args.time_scale else []
    print(format_table(rows(cases) + space_rows(space) + executed_rows(executed)))
    print()
    print(details(cases))
    if executed:
        print(f"\nexecuted (time scale {args.time_scale:g}; seconds of the skills, medians)")
        print(executed_details(executed))
    if args.json:
        out = {"machine": info, "cases": cases, "space": space, "executed": executed}
        args.json.write_text(json.dumps(msgspec.to_builtins(out), indent=1))
    return 0
