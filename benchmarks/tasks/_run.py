"""The many-tasks benchmark: each case's goals submitted all at once and one after the other,
in fresh fleets, alternating which mode goes first (see the package docstring)."""

from __future__ import annotations

import argparse
import logging
import statistics
from collections.abc import Callable, Sequence
from pathlib import Path

import anyio
import msgspec

from benchmarks.common import (
    Row,
    calibrate,
    fmt_num,
    format_grid,
    format_table,
    load_average,
    machine_info,
)

from ._workload import CASES, MODES, Run, run_case

__all__ = ["main", "measure", "rows"]


async def measure(
    cases: Sequence[str],
    robots: int,
    rounds: int,
    time_scale: float,
    say: Callable[[str], None] = print,
) -> list[Run]:
    """``rounds`` runs of each case in each mode; the mode that goes first alternates."""
    runs: list[Run] = []
    for r in range(rounds):
        for case in cases:
            for mode in MODES if r % 2 == 0 else MODES[::-1]:
                run = await run_case(case, mode, robots, time_scale)
                runs.append(run)
                say(_line(run))
    return runs


def _line(run: Run) -> str:
    waited = "; ".join(f"{t} waited for {w}" for t, w in run.waited.items()) or "none waited"
    outcomes = ", ".join(sorted(set(run.outcomes.values())))
    return (
        f"{run.case} {run.mode}: {run.tasks} tasks {outcomes} in {run.makespan:.2f} s "
        f"({run.per_minute:.0f}/min), planning {run.planning:.2f} s, {run.replans} replans; "
        f"{waited}" + (f"; INTERLEAVED on {', '.join(run.interleaved)}" if run.interleaved else "")
    )


def _of(runs: Sequence[Run], case: str, mode: str) -> list[Run]:
    return [r for r in runs if r.case == case and r.mode == mode]


def rows(runs: Sequence[Run]) -> list[Row]:
    """Per case: tasks per minute and makespan at once against one at a time (medians; the
    ratio is the median of the rounds' ratios)."""
    out = []
    for case in dict.fromkeys(r.case for r in runs):
        seq, conc = _of(runs, case, "sequential"), _of(runs, case, "concurrent")
        pairs = [s.makespan / c.makespan for s, c in zip(seq, conc, strict=False)]
        robots, tasks = conc[0].robots, conc[0].tasks
        note = f"{robots} robots, {tasks} tasks"
        out += [
            Row(
                figure=f"{case}: tasks per minute, all at once",
                value=statistics.median(r.per_minute for r in conc),
                unit="/min",
                baseline="one at a time",
                baseline_value=statistics.median(r.per_minute for r in seq),
                note=note,
                paired_ratio=statistics.median(pairs),
            ),
            Row(
                figure=f"{case}: makespan, all at once",
                value=statistics.median(r.makespan for r in conc),
                unit="s",
                baseline="one at a time",
                baseline_value=statistics.median(r.makespan for r in seq),
                note=note,
                paired_ratio=statistics.median(1 / p for p in pairs),
            ),
        ]
    return out


def details(runs: Sequence[Run]) -> str:
    head = ["case", "mode", "runs ok", "makespan s (each run)", "planning s", "replans",
            "waited (tasks: for what)", "robots shared by two tasks' steps"]  # fmt: skip
    body = []
    for case in dict.fromkeys(r.case for r in runs):
        for mode in MODES:
            of = _of(runs, case, mode)
            waits = sorted({f"{t}: {w}" for r in of for t, w in r.waited.items()})
            body.append(
                [
                    case,
                    mode,
                    f"{sum(r.succeeded for r in of)}/{len(of)}",
                    ", ".join(fmt_num(r.makespan) for r in of),
                    fmt_num(statistics.median(r.planning for r in of)),
                    str(sum(r.replans for r in of)),
                    "; ".join(waits) or "none",
                    ", ".join(sorted({a for r in of for a in r.interleaved})) or "none",
                ]
            )
    return format_grid(head, body)


def verdict(runs: Sequence[Run]) -> list[str]:
    """What must hold of every run: every task succeeded, no robot ran steps of two tasks at
    once, and in ``overlapping`` at once the second task waited (its claim) and ended second."""
    problems = [f"{r.case} {r.mode}: {r.outcomes}" for r in runs if not r.succeeded]
    problems += [f"{r.case} {r.mode}: two tasks on {r.interleaved}" for r in runs if r.interleaved]
    for r in _of(runs, "overlapping", "concurrent"):
        second = list(r.outcomes)[1]
        if second not in r.waited or r.finish_order[-1] != second:
            problems.append(f"overlapping: {second} did not wait for the first ({r.waited})")
    return problems


def main(argv: Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.tasks", description=__doc__)
    p.add_argument("--case", action="append", choices=CASES, help="default: every case")
    p.add_argument("--robots", type=int, default=4, help="robots (and tasks per case)")
    p.add_argument("--rounds", type=int, default=3, help="runs of each case in each mode")
    p.add_argument(
        "--time-scale",
        type=float,
        default=0.1,
        help="a simulated run lasts its description's duration times this (navigate 5 s)",
    )
    p.add_argument("--quick", action="store_true", help="2 robots, 1 round, time scale 0.05")
    p.add_argument("--json", type=Path, help="write every run and row as JSON here")
    args = p.parse_args(argv)
    if args.quick:
        args.robots, args.rounds, args.time_scale = 2, 1, 0.05
    logging.basicConfig(level=logging.ERROR)
    info = machine_info()
    print(
        f"machine: {info['cpus_usable']} of {info['cpus']} CPUs, {info['cpu_model']}, "
        f"Python {info['python']}; load {load_average()}; calibration {calibrate():.1f} ms"
    )
    print(f"{args.robots} robots, time scale {args.time_scale:g}, {args.rounds} rounds")
    runs = anyio.run(measure, args.case or CASES, args.robots, args.rounds, args.time_scale)
    table = rows(runs)
    print(format_table(table))
    print(details(runs))
    print(f"load after: {load_average()}")
    problems = verdict(runs)
    for problem in problems:
        print(f"PROBLEM: {problem}")
    if args.json:
        args.json.write_bytes(msgspec.json.encode({"machine": info, "runs": runs, "rows": table}))
    return 1 if problems else 0
