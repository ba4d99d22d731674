"""Shared space: planning with robots counted at the stations beside the same scene with room
for every robot everywhere (every station's ``robotCapacity`` the number of robots: nothing is
counted), solved alternately in one run.

Here each of the kitting scene's two stations holds one robot (``station_capacity=1``), the
depot is open floor; so with more robots than stations the plan sends them to a station in
turns (a robot leaves for the depot before the next one drives in), and the planner's time
includes that. The target: under 1 s at 8 robots x 40 parts.
"""

from __future__ import annotations

import statistics
import time

import msgspec

from benchmarks.common import Row
from task_agent.discovery import agents_from_view
from task_agent.domain import build_task
from task_agent.planning import Engine, Planner, to_partial_order
from tests.assets.planning import KittingScene, kitting_scene

from ._cases import make_goal

__all__ = ["SpaceCase", "run_space", "space_rows"]

TARGET_MS = 1000.0


class SpaceCase(msgspec.Struct, kw_only=True):
    robots: int
    parts: int
    goal: str
    engine: str
    shared_ms: float
    open_ms: float
    shared_steps: int
    open_steps: int
    shared_makespan: float
    open_makespan: float


def _scene(robots: int, parts: int, *, shared: bool) -> KittingScene:
    return kitting_scene(robots, parts, station_capacity=1 if shared else None)


def _plan_ms(scene: KittingScene, goal_kind: str, planner: Planner) -> tuple[float, int, float]:
    goal = make_goal(scene, goal_kind)
    start = time.perf_counter()
    plan = planner.solve(build_task(agents_from_view(scene.view), scene.view, goal))
    elapsed = (time.perf_counter() - start) * 1000.0
    return elapsed, len(plan.steps), to_partial_order(plan).makespan


def run_space(
    robots: int, parts: int, goal_kind: str, engine: Engine, reps: int, timeout: float
) -> SpaceCase:
    """Discovery + generation + solve, with and without robot limits, alternating."""
    planner = Planner(engine=engine, timeout=timeout, decompose=False)
    shared, open_ = _scene(robots, parts, shared=True), _scene(robots, parts, shared=False)
    _plan_ms(shared, goal_kind, planner)  # warm-up
    _plan_ms(open_, goal_kind, planner)
    with_room: list[float] = []
    without: list[float] = []
    for _ in range(reps):
        ms, steps, makespan = _plan_ms(shared, goal_kind, planner)
        with_room.append(ms)
        ms_open, steps_open, makespan_open = _plan_ms(open_, goal_kind, planner)
        without.append(ms_open)
    return SpaceCase(
        robots=robots,
        parts=parts,
        goal=goal_kind,
        engine=engine,
        shared_ms=statistics.median(with_room),
        open_ms=statistics.median(without),
        shared_steps=steps,
        open_steps=steps_open,
        shared_makespan=makespan,
        open_makespan=makespan_open,
    )


def space_rows(cases: list[SpaceCase]) -> list[Row]:
    return [
        Row(
            figure=f"plan {c.robots}x{c.parts} {c.goal}, shared space ({c.engine})",
            value=c.shared_ms,
            unit="ms",
            baseline="room for all robots",
            baseline_value=c.open_ms,
            target=f"< {TARGET_MS:.0f} ms",
            met=c.shared_ms < TARGET_MS,
            note=(
                f"{c.shared_steps} steps (vs {c.open_steps}), makespan "
                f"{c.shared_makespan:.0f} s (vs {c.open_makespan:.0f} s)"
            ),
        )
        for c in cases
    ]
