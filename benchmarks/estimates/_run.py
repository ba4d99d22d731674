"""The estimate-error benchmark: each scenario's mission twice (or ``--runs``) with the MuJoCo
world, learned durations shared through one file (see the package docstring)."""

from __future__ import annotations

import argparse
import logging
import math
import tempfile
from collections.abc import Sequence
from pathlib import Path

import anyio
import msgspec

from benchmarks.common import fmt_num, format_grid
from scenario import load_scenario
from skimesh.commands.demo import mission_goal
from skimesh.commands.sim import scenario_file
from skimesh.demo import MissionView, StackOptions, agent_configs, demo_stack, run_mission
from task_agent import parse_goal
from task_agent.protocol import StepFinished, StepStarted, TaskEvent, TaskOptions

from ._allocation import SLOWER, Allocated, allocation

__all__ = ["Measured", "main", "measure"]

SCENARIOS = ("kitting", "workshop")


class Measured(msgspec.Struct, kw_only=True):
    """One mission run."""

    scenario: str
    run: int
    """0: the warm-up."""
    outcome: str
    estimated: float = math.nan
    actual: float = math.nan
    busy: dict[str, float] = {}
    """Seconds each robot ran steps (task agent's clock)."""
    steps: dict[str, int] = {}
    replans: int = 0

    @property
    def error(self) -> float:
        """(estimated - actual) / actual."""
        return (self.estimated - self.actual) / self.actual if self.actual > 0 else math.nan

    @property
    def busy_share(self) -> float:
        """Total busy time / robots: the makespan of a perfect balance."""
        return sum(self.busy.values()) / len(self.busy) if self.busy else math.nan


class _Busy:
    """Each robot's busy seconds and steps, from the step events' stamps."""

    def __init__(self) -> None:
        self.began: dict[int, StepStarted] = {}
        self.busy: dict[str, float] = {}
        self.steps: dict[str, int] = {}

    def __call__(self, event: TaskEvent) -> None:
        if isinstance(event, StepStarted):
            self.began[event.step] = event
        elif isinstance(event, StepFinished) and event.step in self.began:
            began = self.began.pop(event.step)
            self.busy[began.agent] = self.busy.get(began.agent, 0.0) + event.stamp - began.stamp
            self.steps[began.agent] = self.steps.get(began.agent, 0) + 1


class _View(MissionView):
    """The demo's view, silent, also counting busy time."""

    busy: _Busy | None = None

    def __call__(self, event: TaskEvent) -> None:
        if self.busy is not None:
            self.busy(event)
        super().__call__(event)


async def _one(name: str, run: int, work: Path, durations: Path, fast: bool) -> Measured:
    scenario = load_scenario(scenario_file(name))
    options = StackOptions(
        scenario=scenario,
        agents=agent_configs(scenario),
        data_dir=work / f"{name}-{run}",
        durations=durations,
        fast=fast,
    )
    async with demo_stack(options, None, say=lambda _: None) as stack:
        goal = parse_goal(mission_goal(scenario), stack.wm)
        busy = _Busy()
        view = _View(sim_clock=lambda: stack.world.snapshot.time, out=lambda _: None)
        view.busy = busy
        result = await run_mission(
            stack,
            goal,
            options=TaskOptions(max_replans=5, planner_timeout=60.0),
            view=view,
            stop=anyio.Event(),
            deadline=1800.0,
            out=lambda _: None,
        )
    f = result.finished
    if f is None:
        return Measured(scenario=name, run=run, outcome="no end")
    return Measured(
        scenario=name,
        run=run,
        outcome=f.outcome if result.goal_reached else f"{f.outcome}, goal not reached",
        estimated=f.estimated_makespan if f.estimated_makespan is not None else math.nan,
        actual=f.actual_makespan if f.actual_makespan is not None else math.nan,
        busy=busy.busy,
        steps=busy.steps,
        replans=f.replans,
    )


async def measure(
    scenarios: Sequence[str], runs: int, fast: bool = True, say: object = print
) -> list[Measured]:
    """Every scenario's mission ``runs`` times (see the package docstring); ``fast``: the
    world steps as fast as it can (else in real time)."""
    out: list[Measured] = []
    with tempfile.TemporaryDirectory(prefix="skimesh-estimates-") as tmp:
        work = Path(tmp)
        for name in scenarios:
            durations = work / f"{name}-durations.json"
            for run in range(runs):
                m = await _one(name, run, work, durations, fast)
                out.append(m)
                if callable(say):
                    say(_line(m))
    return out


def _line(m: Measured) -> str:
    robots = ", ".join(
        f"{a} {m.steps.get(a, 0)} steps {b:.1f} s" for a, b in sorted(m.busy.items())
    )
    return (
        f"{m.scenario} run {m.run}: {m.outcome}; estimated {m.estimated:.1f} s, actual "
        f"{m.actual:.1f} s ({m.error:+.1%}); busy/robot {m.busy_share:.1f} s; {robots}"
    )


def table(results: Sequence[Measured]) -> str:
    head = ["scenario", "run", "outcome", "estimated s", "actual s", "error", "busy/robots s",
            "per robot: steps, busy s"]  # fmt: skip
    body = [
        [
            m.scenario,
            "warm-up" if m.run == 0 else str(m.run),
            m.outcome,
            fmt_num(m.estimated),
            fmt_num(m.actual),
            f"{m.error:+.0%}" if not math.isnan(m.error) else "-",
            fmt_num(m.busy_share),
            "; ".join(f"{a} {m.steps.get(a, 0)}, {fmt_num(b)}" for a, b in sorted(m.busy.items())),
        ]
        for m in results
    ]
    return format_grid(head, body)


def allocation_table(rows: Sequence[Allocated]) -> str:
    head = ["durations", "r1 (slow) steps, busy s", "r2 steps, busy s", "makespan s",
            "busy/robots s", "estimated s"]  # fmt: skip
    body = [
        [
            r.durations,
            f"{r.steps.get('r1', 0)}, {fmt_num(r.busy.get('r1', 0.0))}",
            f"{r.steps.get('r2', 0)}, {fmt_num(r.busy.get('r2', 0.0))}",
            fmt_num(r.actual),
            fmt_num(r.busy_share),
            fmt_num(r.estimated),
        ]
        for r in rows
    ]
    return format_grid(head, body)


def main(argv: Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.estimates", description=__doc__)
    p.add_argument("--scenario", action="append", help=f"default: {', '.join(SCENARIOS)}")
    p.add_argument("--runs", type=int, default=2, help="runs per scenario, the first a warm-up")
    p.add_argument("--json", type=Path, help="write the results as JSON here")
    p.add_argument("--no-missions", action="store_true", help="the allocation part only")
    p.add_argument(
        "--realtime", action="store_true", help="the world steps in real time (default: fast)"
    )
    args = p.parse_args(argv)
    logging.basicConfig(level=logging.ERROR)
    allocated = anyio.run(allocation)
    print(f"allocation, r1 {SLOWER:g}x slower than r2 (in-process fleet, simulated outcomes):")
    print(allocation_table(allocated))
    scenarios = args.scenario or SCENARIOS
    results = (
        [] if args.no_missions else anyio.run(measure, scenarios, args.runs, not args.realtime)
    )
    if results:
        print(table(results))
    if args.json:
        args.json.write_bytes(msgspec.json.encode({"missions": results, "allocation": allocated}))
    if args.no_missions:
        return 0
    later = [m for m in results if m.run > 0]
    return 0 if later and all(abs(m.error) <= 0.25 for m in later) else 1
