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

from ._workload import CASES, MODES, Preempted, Run, run_case, run_preemption

__all__ = ["Results", "main", "measure", "rows"]

PREEMPTION = "preemption"


class Results(msgspec.Struct, kw_only=True):
    runs: list[Run] = []
    preemption: list[Preempted] = []


async def measure(
    cases: Sequence[str],
    robots: int,
    rounds: int,
    time_scale: float,
    say: Callable[[str], None] = print,
) -> Results:
    """``rounds`` runs of each case in each mode (and of the preemption case with and
    without preemption); the mode that goes first alternates."""
    out = Results()
    for r in range(rounds):
        for case in cases:
            if case == PREEMPTION:
                for preempt in (True, False) if r % 2 == 0 else (False, True):
                    p = await run_preemption(preempt, robots, time_scale)
                    out.preemption.append(p)
                    say(_preempted_line(p))
                continue
            for mode in MODES if r % 2 == 0 else MODES[::-1]:
                run = await run_case(case, mode, robots, time_scale)
                out.runs.append(run)
                say(_line(run))
    return out


def _preempted_line(p: Preempted) -> str:
    how = "preemptible" if p.preemption else "not preemptible"
    return (
        f"preemption, long task {how}: {p.outcomes}; urgent task {p.high_turnaround:.2f} s "
        f"from submission to end, long task {p.low_makespan:.2f} s; "
        f"{'urgent first' if p.high_first else 'long first'}"
        + ("; the long task gave way" if p.gave_way else "")
    )


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


def rows(runs: Sequence[Run], preempted: Sequence[Preempted] = ()) -> list[Row]:
    """Per case: tasks per minute and makespan at once against one at a time (medians; the
    ratio is the median of the rounds' ratios); the preemption case's turnarounds with and
    without preemption."""
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
    return out + (_preemption_rows(preempted) if preempted else [])


def _preemption_rows(preempted: Sequence[Preempted]) -> list[Row]:
    yes = [p for p in preempted if p.preemption]
    no = [p for p in preempted if not p.preemption]
    pairs = list(zip(yes, no, strict=False))

    def row(figure: str, of: Callable[[Preempted], float]) -> Row:
        return Row(
            figure=f"preemption: {figure}",
            value=statistics.median(of(p) for p in yes),
            unit="s",
            baseline="not preemptible",
            baseline_value=statistics.median(of(p) for p in no),
            note="long task 9 steps on r1, urgent 3",
            paired_ratio=statistics.median(of(a) / of(b) for a, b in pairs),
        )

    return [
        row("urgent task, submission to end", lambda p: p.high_turnaround),
        row("long task, submission to end", lambda p: p.low_makespan),
        row("both tasks' makespan", lambda p: p.makespan),
    ]


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


def verdict(runs: Sequence[Run], preempted: Sequence[Preempted] = ()) -> list[str]:
    """What must hold of every run: every task succeeded, no robot ran steps of two tasks at
    once, in ``overlapping`` at once the second task waited (its claim) and ended second, and
    a preemptible long task gave way to the urgent one, which ended first."""
    problems = [f"{r.case} {r.mode}: {r.outcomes}" for r in runs if not r.succeeded]
    for p in preempted:
        if not p.succeeded or p.interleaved:
            problems.append(f"preemption: {p.outcomes}, two tasks on {p.interleaved}")
        if p.preemption and not (p.gave_way and p.high_first):
            problems.append("preemption: the long task did not give way to the urgent one")
    problems += [f"{r.case} {r.mode}: two tasks on {r.interleaved}" for r in runs if r.interleaved]
    for r in _of(runs, "overlapping", "concurrent"):
        second = list(r.outcomes)[1]
        if second not in r.waited or r.finish_order[-1] != second:
            problems.append(f"overlapping: {second} did not wait for the first ({r.waited})")
    return problems


def main(argv: Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.tasks", description=__doc__)
    p.add_argument(
        "--case", action="append", choices=[*CASES, PREEMPTION], help="default: every case"
    )
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
    cases = args.case or [*CASES, PREEMPTION]
    results = anyio.run(measure, cases, args.robots, args.rounds, args.time_scale)
    runs, preempted = results.runs, results.preemption
    table = rows(runs, preempted)
    print(format_table(table))
    if runs:
        print(details(runs))
    print(f"load after: {load_average()}")
    problems = verdict(runs, preempted)
    for problem in problems:
        print(f"PROBLEM: {problem}")
    if args.json:
        args.json.write_bytes(
            msgspec.json.encode({"machine": info, "results": results, "rows": table})
        )
    return 1 if problems else 0
