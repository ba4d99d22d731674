"""The fleet-planning benchmark (see the package docstring)."""

from __future__ import annotations

import argparse
import json
import math
import resource
import statistics
import subprocess
import sys
import time
from collections.abc import Sequence
from pathlib import Path

import msgspec

from benchmarks.common import Row, format_table, load_average, machine_info
from task_agent import PlannerTimeoutError
from task_agent.discovery import agents_from_view
from task_agent.planning import Plan, Planner, to_partial_order
from tests.assets.planning.fleet import fleet_scene, one_gear_each

__all__ = ["Case", "main", "measure"]

SIZES = (1, 10, 25, 50, 100)


class Case(msgspec.Struct, kw_only=True):
    """One fleet size and goal, measured in one child process."""

    robots: int
    goal: str
    """``all`` or ``one``."""
    objects: int = 0
    actions: int = 0
    steps: int = 0
    plan_s: float = math.nan
    """Build the task and plan it, decomposed (median)."""
    parts: int = 0
    solved_objects: int = 0
    makespan: float = math.nan
    monolithic_s: float = math.nan
    monolithic_makespan: float = math.nan
    monolithic: str = "ok"
    """``ok``, ``skipped`` or ``timeout (S s)``."""
    order_s: float = math.nan
    peak_mb: float = math.nan


def _plan(planner: Planner, n: int, goal_kind: str) -> tuple[float, Plan]:
    fleet = fleet_scene(n)
    goal = one_gear_each(fleet, [0] if goal_kind == "one" else None)
    agents = agents_from_view(fleet.view)  # the task agent keeps them (discovery)
    start = time.perf_counter()
    plan = planner.plan_sync(agents, fleet.view, goal)
    return time.perf_counter() - start, plan


def measure(n: int, goal_kind: str, reps: int, monolithic_limit: float) -> Case:
    """One case (see the package docstring), in this process."""
    case = Case(robots=n, goal=goal_kind)
    planner = Planner(timeout=max(60.0, monolithic_limit))
    _plan(planner, n, goal_kind)  # warm-up: imports, environments, caches
    times: list[float] = []
    plan: Plan | None = None
    for _ in range(reps):
        seconds, plan = _plan(planner, n, goal_kind)
        times.append(seconds)
    assert plan is not None
    case.plan_s = statistics.median(times)
    case.objects, case.actions = plan.stats.objects, len(plan.task.actions)
    case.steps, case.parts = len(plan.steps), plan.stats.parts
    case.solved_objects = plan.stats.objects_solved
    start = time.perf_counter()
    case.makespan = to_partial_order(plan).makespan
    case.order_s = time.perf_counter() - start
    if monolithic_limit <= 0:
        case.monolithic = "skipped"
    else:
        whole = Planner(timeout=monolithic_limit, decompose=False)
        try:
            case.monolithic_s, mono = _plan(whole, n, goal_kind)
            case.monolithic_makespan = to_partial_order(mono).makespan
        except PlannerTimeoutError:
            case.monolithic = f"timeout ({monolithic_limit:g} s)"
    case.peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    return case


def _child(n: int, goal_kind: str, reps: int, limit: float) -> Case:
    cmd = [sys.executable, "-m", "benchmarks.fleet", "--child", str(n), goal_kind]
    cmd += ["--reps", str(reps), "--monolithic-limit", str(limit)]
    out = subprocess.run(cmd, check=True, capture_output=True, text=True, timeout=3600)
    return msgspec.convert(json.loads(out.stdout.strip().splitlines()[-1]), Case)


def rows(cases: Sequence[Case]) -> list[Row]:
    by = {(c.robots, c.goal): c for c in cases}
    base = by.get((1, "one"))
    out: list[Row] = []
    for c in cases:
        name = f"{c.robots} robots, {'one robot' if c.goal == 'one' else 'every robot'}"
        target, met = "", None
        if c.goal == "all" and c.robots in (50, 100):
            limit = 2.0 if c.robots == 50 else 5.0
            target, met = f"< {limit:g} s", c.plan_s < limit
        out.append(Row(figure=f"plan {name}", value=c.plan_s, unit="s", target=target, met=met))
        if c.goal == "one" and base is not None and c is not base:
            aimed = c.robots <= 50  # the target is set for 50 robots; 100 is shown beside it
            out.append(
                Row(
                    figure=f"plan {name} vs 1 robot",
                    value=c.plan_s,
                    unit="s",
                    baseline="1-robot world",
                    baseline_value=base.plan_s,
                    target="<= 2x" if aimed else "",
                    met=c.plan_s <= 2 * base.plan_s if aimed else None,
                )
            )
        if not math.isnan(c.monolithic_makespan):
            out.append(
                Row(
                    figure=f"makespan {name}",
                    value=c.makespan,
                    unit="s",
                    baseline="monolithic",
                    baseline_value=c.monolithic_makespan,
                    target="<= 1.1x",
                    met=c.makespan <= 1.1 * c.monolithic_makespan + 1e-9,
                )
            )
        out.append(
            Row(
                figure=f"peak memory {name}",
                value=c.peak_mb,
                unit="MB",
                target="< 1024 MB" if c.robots == 100 else "",
                met=c.peak_mb < 1024 if c.robots == 100 else None,
            )
        )
    return out


def details(cases: Sequence[Case]) -> str:
    head = "robots | goal | objects | actions | steps | parts | largest problem | plan (s) | "
    head += "order (s) | makespan | monolithic (s) | monolithic makespan"
    lines = [head, "|".join("---" for _ in head.split("|"))]
    for c in cases:
        mono = f"{c.monolithic_s:.2f}" if c.monolithic == "ok" else c.monolithic
        lines.append(
            f"{c.robots} | {c.goal} | {c.objects} | {c.actions} | {c.steps} | {c.parts} | "
            f"{c.solved_objects} | {c.plan_s:.3f} | {c.order_s:.3f} | {c.makespan:g} | {mono} | "
            f"{c.monolithic_makespan:g}"
        )
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.fleet", description=__doc__)
    p.add_argument("--robots", type=int, nargs="*", default=list(SIZES))
    p.add_argument("--reps", type=int, default=3)
    p.add_argument(
        "--monolithic-limit",
        type=float,
        default=60.0,
        metavar="S",
        help="time-out of the monolithic oracle (0: skip it); default 60",
    )
    p.add_argument("--monolithic-up-to", type=int, default=25, metavar="N")
    p.add_argument("--json", type=Path)
    p.add_argument("--child", nargs=2, metavar=("N", "GOAL"), help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.child:
        case = measure(int(args.child[0]), args.child[1], args.reps, args.monolithic_limit)
        print(json.dumps(msgspec.to_builtins(case)))  # NaN survives, unlike in msgspec's JSON
        return 0
    cases = []
    for n in args.robots:
        for goal in ("one", "all"):
            limit = args.monolithic_limit if n <= args.monolithic_up_to else 0.0
            cases.append(_child(n, goal, args.reps, limit))
            print(f"measured {n} robots, {goal}", file=sys.stderr)
    print(machine_info(["unified-planning", "up-kairos", "scipy"]), f"load {load_average()}")
    print(format_table(rows(cases)))
    print()
    print(details(cases))
    if args.json:
        args.json.write_text(json.dumps([msgspec.to_builtins(c) for c in cases], indent=1))
    return 0
