"""The planning benchmark's cases: plan time of ours beside the raw engine on the emitted PDDL,
and the estimated makespan of the partial order beside the sequential plan."""

from __future__ import annotations

import math
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import kairos
import msgspec

from benchmarks.common import Row, fmt_num, format_grid
from task_agent import Goal, PlannerTimeoutError, parse_goal
from task_agent.discovery import agents_from_view
from task_agent.domain import build_task
from task_agent.planning import FD_SEARCH, Engine, Plan, Planner, to_partial_order
from tests.assets.planning import KittingScene, kitting_scene

SIZES = [(2, 4), (3, 8), (4, 12), (5, 20), (5, 40), (8, 40)]
QUICK_SIZES = [(2, 4), (3, 8)]
ENGINES: list[Engine] = ["kairos", "fast-downward"]
FD_DRIVER = (
    Path(sys.modules["up_fast_downward"].__file__ or "").parent / "downward/fast-downward.py"
)


class Case(msgspec.Struct, kw_only=True):
    robots: int
    parts: int
    goal: str
    engine: str
    status: str = "ok"
    objects: int = 0
    objects_solved: int = 0
    steps: int = 0
    generate_ms: float = math.nan
    convert_ms: float = math.nan
    engine_call_ms: float = math.nan
    engine_own_ms: float = math.nan
    ours_ms: float = math.nan
    raw_ms: float = math.nan
    order_ms: float = math.nan
    makespan: float = math.nan
    sequential: float = math.nan
    ratio: float = math.nan
    """Median over repetitions of ours / raw engine."""
    up_ratio: float = math.nan
    """Median over repetitions of the engine call through unified-planning / raw engine."""

    @property
    def name(self) -> str:
        return f"{self.robots}x{self.parts} {self.goal}"


def make_goal(scene: KittingScene, kind: str) -> Goal:
    robots = len(scene.kits)
    parts = scene.parts[: 2 * robots] if kind == "two" else scene.parts
    text = " and ".join(f"contain({scene.kits[i % robots]}, {p})" for i, p in enumerate(parts))
    return parse_goal(text, scene.view)


def raw_kairos(domain: str, problem: str, timeout: float) -> float:
    start = time.perf_counter()
    result = kairos.solve(domain, problem, anytime=False, timeout=timeout)
    elapsed = time.perf_counter() - start
    if result.status != kairos.Status.SOLVED:
        raise RuntimeError(f"kairos on the emitted PDDL: {result.status}")
    return elapsed


def raw_fast_downward(domain: Path, problem: Path, timeout: float) -> float:
    with tempfile.TemporaryDirectory() as work:
        cmd = [
            sys.executable,
            str(FD_DRIVER),
            "--plan-file",
            "plan.txt",
            "--search-time-limit",
            f"{math.ceil(timeout)}s",
        ]
        cmd += [str(domain), str(problem), "--search-options", "--search", FD_SEARCH]
        start = time.perf_counter()
        done = subprocess.run(cmd, cwd=work, capture_output=True, timeout=timeout + 30, check=False)
        elapsed = time.perf_counter() - start
        if done.returncode != 0 or not (Path(work) / "plan.txt").exists():
            why = done.stderr.decode()[-500:]
            raise RuntimeError(f"fast downward on the emitted PDDL: exit {done.returncode}: {why}")
    return elapsed


def median_ms(samples: list[float]) -> float:
    return statistics.median(samples) * 1000.0 if samples else math.nan


def _ours(scene: KittingScene, goal: Goal, planner: Planner) -> tuple[float, float, Plan]:
    """(total seconds, generation seconds, plan) of discovery + generation + solve."""
    start = time.perf_counter()
    task = build_task(agents_from_view(scene.view), scene.view, goal)
    built = time.perf_counter()
    plan = planner.solve(task)
    return time.perf_counter() - start, built - start, plan


def run_case(
    robots: int, parts: int, goal_kind: str, engine: Engine, reps: int, timeout: float
) -> Case:
    """Ours and the raw engine alternate, so both see the same machine load; the ratio is
    the median of the per-repetition ratios."""
    case = Case(robots=robots, parts=parts, goal=goal_kind, engine=engine)
    scene = kitting_scene(robots, parts)
    goal = make_goal(scene, goal_kind)
    planner = Planner(engine=engine, timeout=timeout, decompose=False)
    try:
        _, _, plan = _ours(scene, goal, planner)  # warm-up: imports, caches
    except PlannerTimeoutError:
        case.status = f"timeout ({timeout:g} s)"
        return case
    with tempfile.TemporaryDirectory() as tmp:
        domain, problem = planner.emit_pddl(plan.task, tmp, compressed=not plan.stats.fallback)
        raw: Callable[[], float]
        if engine == "kairos":
            texts = domain.read_text(), problem.read_text()
            raw = lambda: raw_kairos(*texts, timeout)  # noqa: E731
        else:
            raw = lambda: raw_fast_downward(domain, problem, timeout)  # noqa: E731
        raw()  # warm-up
        ours, generate, convert, call, own, raws = [], [], [], [], [], []
        for _ in range(reps):
            total, gen, plan = _ours(scene, goal, planner)
            ours.append(total)
            generate.append(gen)
            convert.append(plan.stats.convert_s)
            call.append(plan.stats.solve_s)
            own.append(plan.stats.engine_s)
            raws.append(raw())
    case.ours_ms, case.generate_ms = median_ms(ours), median_ms(generate)
    case.convert_ms, case.engine_call_ms = median_ms(convert), median_ms(call)
    case.engine_own_ms = median_ms([x for x in own if not math.isnan(x)])
    case.raw_ms = median_ms(raws)
    case.ratio = statistics.median(o / r for o, r in zip(ours, raws, strict=True))
    case.up_ratio = statistics.median(c / r for c, r in zip(call, raws, strict=True))
    case.objects, case.objects_solved = plan.stats.objects, plan.stats.objects_solved
    case.steps = len(plan.steps)
    start = time.perf_counter()
    po = to_partial_order(plan)
    case.order_ms = (time.perf_counter() - start) * 1000.0
    case.makespan, case.sequential = po.makespan, po.sequential
    return case


def rows(cases: list[Case]) -> list[Row]:
    out = []
    for c in cases:
        if c.status != "ok":
            out.append(
                Row(figure=f"plan {c.name} ({c.engine})", value=math.nan, unit="ms", note=c.status)
            )
            continue
        out.append(
            Row(
                figure=f"plan {c.name} ({c.engine})",
                value=c.ours_ms,
                unit="ms",
                baseline="raw engine, same PDDL",
                baseline_value=c.raw_ms,
                target="< 1.5x",
                met=c.ratio < 1.5,
                note=f"{c.ratio:.2f}x per-run",
            )
        )
    for c in cases:
        if c.status == "ok" and c.engine == "kairos":
            ideal = 1.0 / c.robots
            share = c.makespan / c.sequential
            out.append(
                Row(
                    figure=f"makespan {c.name}",
                    value=c.makespan,
                    unit="s",
                    baseline="sequential",
                    baseline_value=c.sequential,
                    target=f"~{ideal:.2f}x",
                    met=share <= ideal * 1.25,
                )
            )
    return out


def details(cases: list[Case]) -> str:
    head = (
        "case",
        "engine",
        "objects (solved)",
        "steps",
        "generate ms",
        "convert ms",
        "engine call ms",
        "engine's own ms",
        "ours ms",
        "raw ms",
        "ratio",
        "UP call/raw",
        "order ms",
        "makespan/seq",
    )
    body = []
    for c in cases:
        if c.status != "ok":
            body.append((c.name, c.engine, c.status, *("-",) * 11))
            continue
        body.append(
            (
                c.name,
                c.engine,
                f"{c.objects} ({c.objects_solved})",
                str(c.steps),
                fmt_num(c.generate_ms),
                fmt_num(c.convert_ms),
                fmt_num(c.engine_call_ms),
                fmt_num(c.engine_own_ms),
                fmt_num(c.ours_ms),
                fmt_num(c.raw_ms),
                f"{c.ratio:.2f}x",
                f"{c.up_ratio:.2f}x",
                fmt_num(c.order_ms),
                f"{c.makespan:.0f}/{c.sequential:.0f} = "
                f"{c.makespan / c.sequential:.2f} (1/{c.robots})",
            )
        )
    return format_grid(head, body)
