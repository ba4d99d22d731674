"""Shared space in the planner: a place that holds one robot (``robotCapacity`` absent or 1)
is never planned for two robots at once, one for no robot never for any, and the partial order
keeps a second robot's arrival after the first one's departure, in every order the robots may
run it."""

from __future__ import annotations

import itertools
import random

import pytest

from task_agent import parse_goal
from task_agent.discovery import agents_from_view
from task_agent.domain import Lit, PlanningTask, build_task
from task_agent.planning import Engine, PartialOrderPlan, Planner, to_partial_order
from task_agent.reachability import replay
from tests.assets.planning import KittingScene, apply_ops, kitting_scene
from tests.unit.task_agent.test_partial_order import linear_extensions
from wm_store.protocol import UpdateElement

ENGINES: list[Engine] = ["kairos", "fast-downward"]


def one_station(robots: int = 2) -> tuple[KittingScene, PlanningTask]:
    """Every part on one station's shelf; each robot's kit wants one of them."""
    scene = kitting_scene(robots, 2 * robots, stations=1, station_capacity=1)
    goal = " and ".join(f"contain({k}, {p})" for k, p in zip(scene.kits, scene.parts, strict=False))
    view = scene.view
    return scene, build_task(agents_from_view(view), view, parse_goal(goal, view))


def occupancy_peaks(task: PlanningTask, po: PartialOrderPlan, order: list[int]) -> dict[str, int]:
    """Most robots at once at each location, running the steps in ``order`` (every step
    running at once with those not ordered before it counts)."""
    at = {
        args[0]: args[1] for pred, args in task.init if pred == "at" and args[0].startswith("Mob")
    }
    peak: dict[str, int] = {}
    for i in order:
        step = po.steps[i].step
        if step.skill == "navigate":
            at[step.params["robot"]] = step.params["goal"]
        for place in set(at.values()):
            peak[place] = max(peak.get(place, 0), list(at.values()).count(place))
    return peak


def test_spots_get_free_facts_and_moving_actions_take_and_leave_them() -> None:
    scene, task = one_station()
    station = scene.stations[0]
    assert ("free_spot", (station,)) in task.init  # nobody there
    assert ("free_spot", (scene.depot,)) not in task.init  # open floor: not counted
    assert ("open_place", (scene.depot,)) in task.init
    assert ("open_place", (station,)) not in task.init
    nav = task.actions["navigate__r1"]
    assert Lit("free_spot", ("?goal",)) in nav.pre
    assert Lit("free_spot", ("?goal",), False) in nav.delete
    assert Lit("free_spot", ("?start",)) in nav.add
    to_open = task.actions["navigate__r1__open"]
    assert Lit("open_place", ("?goal",)) in to_open.pre
    assert not any(lit.pred == "free_spot" for lit in (*to_open.pre, *to_open.delete))
    assert Lit("free_spot", ("?start",)) in to_open.add  # leaving a spot frees it
    assert task.predicates["open_place"].static and not task.predicates["free_spot"].static
    pick = task.actions["pick__r1"]  # moves no robot: unchanged
    assert not any(lit.pred in ("free_spot", "open_place") for lit in (*pick.pre, *pick.add))


def test_an_occupied_spot_is_not_free_and_a_place_for_no_robot_is_never_a_goal() -> None:
    scene = kitting_scene(2, 4, stations=2, station_capacity=1)
    depot, s1, s2 = scene.depot, *scene.stations
    # every place a spot (the depot holds one robot too): no open variants
    apply_ops(scene, [UpdateElement(id=depot, properties={"robotCapacity": 1})])
    view = scene.view
    goal = parse_goal(f"contain({scene.kits[0]}, {scene.parts[2]})", view)  # at station 2
    task = build_task(agents_from_view(view), view, goal)
    assert ("free_spot", (depot,)) not in task.init  # the robots stand there
    assert ("free_spot", (s1,)) in task.init and ("free_spot", (s2,)) in task.init
    assert "open_place" not in task.predicates and "navigate__r1__open" not in task.actions
    # station 1 holds no robot: only station 2 is a goal the planner may choose
    apply_ops(scene, [UpdateElement(id=s1, properties={"robotCapacity": 0})])
    task = build_task(agents_from_view(view), view, goal)
    assert ("free_spot", (s1,)) not in task.init and ("open_place", (s1,)) not in task.init
    plan = Planner().solve(task)
    assert all(s.params.get("goal") != s1 for s in plan.steps if s.skill == "navigate")


@pytest.mark.parametrize("engine", ENGINES)
def test_two_robots_for_one_station_take_turns(engine: Engine) -> None:
    scene, task = one_station()
    plan = Planner(engine=engine).solve(task)
    station = scene.stations[0]
    arrivals = [s for s in plan.steps if s.skill == "navigate" and s.params["goal"] == station]
    assert {s.agent for s in arrivals} == {"r1", "r2"}  # both robots work there...
    po = to_partial_order(plan)
    steps = [s.step for s in po.steps]
    first_in = min(
        (i for i, s in enumerate(steps) if s.skill == "navigate" and s.params["goal"] == station),
    )
    first = steps[first_in].agent
    leaves = next(
        i
        for i, s in enumerate(steps)
        if s.skill == "navigate" and s.agent == first and s.params["start"] == station
    )
    second_in = next(
        i
        for i, s in enumerate(steps)
        if s.skill == "navigate" and s.agent != first and s.params["goal"] == station
    )
    # ...one after the other: the arrival is ordered after the departure, for free_spot
    assert any(
        e.before == leaves and e.after == second_in and e.what == f"free_spot({station})"
        for e in po.edges
    )
    assert po.steps[second_in].start >= po.steps[leaves].finish
    rng = random.Random(3)
    for order in linear_extensions(po, rng, 30):
        _, problem = replay(task, [po.steps[i].step.ground for i in order])
        assert problem == ""
        assert occupancy_peaks(task, po, order).get(station, 0) <= 1


def test_three_robots_for_one_station_plan_fast() -> None:
    scene, task = one_station(3)
    plan = Planner(engine="kairos").solve(task)
    po = to_partial_order(plan)
    station = scene.stations[0]
    arrivals = [
        i
        for i, s in enumerate(po.steps)
        if s.step.skill == "navigate" and s.step.params["goal"] == station
    ]
    assert len(arrivals) == 3
    # at most one robot at the station in the schedule: the stays do not overlap
    stays = []
    for i in arrivals:
        agent = po.steps[i].step.agent
        out = next(
            (
                j
                for j, s in enumerate(po.steps)
                if j > i and s.step.agent == agent and s.step.skill == "navigate"
            ),
            None,
        )
        stays.append((po.steps[i].start, po.steps[out].finish if out is not None else 1e9))
    stays.sort()
    for (_, end), (begin, _) in itertools.pairwise(stays):
        assert begin >= end - 1e-9


def test_room_for_every_robot_leaves_the_domain_as_it_was() -> None:
    scene = kitting_scene(2, 4)  # every place has room for both robots
    view = scene.view
    goal = parse_goal(f"contain({scene.kits[0]}, {scene.parts[2]})", view)
    task = build_task(agents_from_view(view), view, goal)
    assert "free_spot" not in task.predicates and "open_place" not in task.predicates
    assert sorted(n for n in task.actions if n.startswith("navigate")) == [
        "navigate__r1",
        "navigate__r2",
    ]
    # a station for no robot: the others stay open, the action keeps its name
    apply_ops(scene, [UpdateElement(id=scene.stations[0], properties={"robotCapacity": 0})])
    task = build_task(agents_from_view(view), view, goal)
    assert Lit("open_place", ("?goal",)) in task.actions["navigate__r1"].pre
    assert "free_spot" not in task.predicates and "navigate__r1__open" not in task.actions
    assert ("open_place", (scene.stations[0],)) not in task.init
