"""Planning that follows the goal (task_agent.planning's decomposed path), with the monolithic
planner as the oracle: goal parts, the fact graph and its hubs, the allocation, small problems
that widen until they hold on the full task, and the fallback to the whole task."""

from __future__ import annotations

import msgspec
import pytest

from task_agent import PlannerTimeoutError, UnsolvableError, parse_goal
from task_agent.discovery import agents_from_view
from task_agent.domain import GroundFact, Lit, PlanningTask, build_task
from task_agent.learning import positions
from task_agent.planning import (
    DECOMPOSE_FROM,
    Plan,
    Planner,
    PlanStep,
    exclude_steps,
    to_partial_order,
)
from task_agent.planning import _allocate as allocate_module
from task_agent.planning import _planner as planner_module
from task_agent.planning._allocate import _assign, allocate
from task_agent.planning._nearby import nearby_agents
from task_agent.planning._parts import FactGraph, parts
from task_agent.reachability import State, apply, replay
from tests.assets.planning.fleet import Fleet, fleet_scene, one_gear_each
from tests.unit.task_agent.test_planner import oven_task

SPLIT = Planner(decompose_from=0)
"""Plans by parts whatever the task's size."""


def task_of(fleet: Fleet, text: str) -> PlanningTask:
    goal = parse_goal(text, fleet.view)
    return build_task(agents_from_view(fleet.view), fleet.view, goal)


def valid(plan: Plan) -> bool:
    return replay(plan.task, [s.ground for s in plan.steps])[1] == ""


def test_literals_that_share_an_element_are_one_part() -> None:
    goal = (
        Lit("contain", ("kit-1", "gear-1")),
        Lit("contain", ("kit-2", "gear-2")),
        Lit("contain", ("kit-1", "gear-3")),
        Lit("doorOpen", ("oven",), positive=False),
    )
    assert parts(goal) == [(goal[0], goal[2]), (goal[1],), (goal[3],)]


def test_a_hub_is_reached_but_not_crossed() -> None:
    facts = [("at", (f"robot-{i}", "depot")) for i in range(10)]
    facts += [("owns", ("robot-1", "gripper-1")), ("owns", ("robot-2", "gripper-2"))]
    objects = {o: "thing" for _, args in facts for o in args}
    graph = FactGraph(facts, objects)
    assert graph.focus({"robot-1"}, depth=3, hub=4) == {"robot-1", "gripper-1", "depot"}
    # not a hub: the depot leads to every robot
    assert "gripper-2" in graph.focus({"robot-1"}, depth=3, hub=20)


def test_each_kit_goes_to_the_robot_that_carries_it() -> None:
    fleet = fleet_scene(6)
    task = task_of(
        fleet,
        " and ".join(f"contain({k}, {g[0]})" for k, g in zip(fleet.kits, fleet.gears, strict=True)),
    )
    goal_parts = parts(task.goal)
    graph = FactGraph(task.init, task.objects)
    allocation = allocate(task, goal_parts, graph, positions(fleet.view, task.objects))
    assigned = [r[0] for r in allocation.ranking]
    assert assigned == fleet.agents
    assert all(len(r) == len(fleet.agents) for r in allocation.ranking)


def test_parts_any_robot_can_take_are_spread_over_them() -> None:
    bids = {(i, a): 1.0 for i in range(4) for a in ("r1", "r2")}
    bids[(0, "r1")] = 0.5  # r1 is nearer to part 0
    assigned = _assign(4, ["r1", "r2"], bids)
    assert assigned[0] == "r1"
    assert sorted(assigned.values()) == ["r1", "r1", "r2", "r2"]


def test_the_decomposed_plan_matches_the_monolithic_one() -> None:
    fleet = fleet_scene(6)
    goal = one_gear_each(fleet)
    task = build_task(agents_from_view(fleet.view), fleet.view, goal)
    where = positions(fleet.view, task.objects)
    split = SPLIT.solve(task, where=where)
    whole = Planner(decompose=False).solve(task)
    assert split.stats.parts == 6 and split.stats.widened == 0
    assert whole.stats.parts == 0
    assert valid(split) and valid(whole)
    assert split.stats.objects_solved < len(task.objects) / 2
    assert {s.agent for s in split.steps} == set(fleet.agents)
    ours, oracle = to_partial_order(split).makespan, to_partial_order(whole).makespan
    assert ours <= oracle * 1.1


def test_a_goal_for_one_robot_stays_small_in_a_large_world() -> None:
    fleet = fleet_scene(30)
    task = task_of(fleet, f"contain({fleet.kits[7]}, {fleet.gears[7][1]})")
    plan = SPLIT.solve(task)
    assert valid(plan) and {s.agent for s in plan.steps} == {"r8"}
    assert plan.stats.parts == 1 and plan.stats.objects_solved <= 15


def test_a_robot_in_the_way_is_planned_with_the_part_that_needs_its_spot() -> None:
    # Both robots start at their own one-robot station; each needs a gear of the other's
    # cell: the first part's robot alone finds the station taken, so the part widens to
    # the robot standing there, which makes room.
    fleet = fleet_scene(2, start="cells")
    text = (
        f"contain({fleet.kits[0]}, {fleet.gears[1][0]}) and "
        f"contain({fleet.kits[1]}, {fleet.gears[0][0]})"
    )
    task = task_of(fleet, text)
    plan = SPLIT.solve(task)
    assert valid(plan)
    assert plan.stats.parts == 2 and plan.stats.widened >= 1


def test_a_helper_agent_joins_the_part_that_needs_it() -> None:
    _, task = oven_task(can_open=True)
    plan = SPLIT.solve(task)
    assert valid(plan)
    assert "oven-agent" in {s.agent for s in plan.steps}
    assert plan.stats.parts >= 1 and plan.stats.widened >= 1


def test_an_unsolvable_goal_is_reported_by_the_whole_task() -> None:
    # a gear in a closed oven nobody can open: every part fails, the whole task says why
    _, task = oven_task(can_open=False)
    with pytest.raises(UnsolvableError, match="unreachable"):
        Planner(timeout=20, decompose_from=0).solve(task)


@pytest.mark.parametrize("swap", [0, 1, 2])
def test_kit_goals_across_cells_agree_with_the_oracle(swap: int) -> None:
    # gears of other cells into the kits: every robot must take another's one-robot spot,
    # so the parts are coupled (planned together at the second level)
    fleet = fleet_scene(3, start="cells")
    chosen = [(i, (i + swap) % 3) for i in range(3)]
    text = " and ".join(f"contain({fleet.kits[i]}, {fleet.gears[j][0]})" for i, j in chosen)
    task = task_of(fleet, text)
    split = SPLIT.solve(task)
    whole = Planner(decompose=False).solve(task)
    assert valid(split) and valid(whole)
    assert split.stats.parts == 3


def test_the_task_is_built_for_the_agents_near_a_small_goal() -> None:
    fleet = fleet_scene(30)
    goal = parse_goal(f"contain({fleet.kits[7]}, {fleet.gears[7][1]})", fleet.view)
    agents = agents_from_view(fleet.view)
    assert [a.name for a in nearby_agents(agents, fleet.view, goal) or []] == ["r8"]
    plan = SPLIT.plan_sync(agents, fleet.view, goal)
    assert valid(plan) and {s.agent for s in plan.steps} == {"r8"}
    assert {a.agent for a in plan.task.actions.values()} == {"r8"}
    # a goal for most of the fleet is built for all of it at once
    assert nearby_agents(agents, fleet.view, one_gear_each(fleet, range(20))) is None


def test_agents_left_out_are_taken_in_when_the_near_ones_have_no_plan(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    fleet = fleet_scene(10)
    goal = parse_goal(f"contain({fleet.kits[3]}, {fleet.gears[3][0]})", fleet.view)
    agents = agents_from_view(fleet.view)
    # only r1 is "near": it cannot fill r4's kit, so the task is built again for everyone
    monkeypatch.setattr(planner_module, "nearby_agents", lambda a, v, g: [agents[0]])
    plan = SPLIT.plan_sync(agents, fleet.view, goal)
    assert valid(plan) and {s.agent for s in plan.steps} == {"r4"}


def test_running_out_of_time_says_how_many_parts_were_planned() -> None:
    fleet = fleet_scene(40)
    task = task_of(
        fleet,
        " and ".join(f"contain({k}, {g[0]})" for k, g in zip(fleet.kits, fleet.gears, strict=True)),
    )
    with pytest.raises(PlannerTimeoutError, match=r"planned \d+ of 40 goal parts"):
        Planner(timeout=0.05).solve(task)


def test_a_small_goal_with_parts_for_two_robots_is_allocated_before_planning() -> None:
    # two trays' worth of goal on a small site: planned by parts (one per robot), not whole
    fleet = fleet_scene(2, start="cells")
    two = [f"contain({fleet.kits[i]}, {fleet.gears[i][0]})" for i in (0, 1)]
    task = task_of(fleet, " and ".join(two))
    assert len(task.objects) < DECOMPOSE_FROM
    plan = Planner().solve(task)
    assert plan.stats.parts == 2 and {s.agent for s in plan.steps} == {"r1", "r2"}
    # one part, or one agent: the whole task
    one = task_of(fleet, f"contain({fleet.kits[0]}, {fleet.gears[0][0]})")
    assert Planner().solve(one).stats.parts == 0


def test_a_goal_too_large_for_the_assignment_is_allocated_greedily(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    bids = {(i, a): 1.0 for i in range(6) for a in ("r1", "r2", "r3")}
    bids[(4, "r3")] = 0.1  # r3 is nearest to part 4
    monkeypatch.setattr(allocate_module, "ASSIGN_CELLS", 10)
    assigned = _assign(6, ["r1", "r2", "r3"], bids)
    assert assigned[4] == "r3"
    assert sorted(assigned.values()) == ["r1", "r1", "r2", "r2", "r3", "r3"]


def test_a_replan_keeps_the_parts_a_failure_did_not_touch() -> None:
    fleet = fleet_scene(4)
    task = task_of(
        fleet,
        " and ".join(f"contain({k}, {g[0]})" for k, g in zip(fleet.kits, fleet.gears, strict=True)),
    )
    first = SPLIT.solve(task)
    assert first.stats.parts == 4 and len(first.blocks) == 4
    # nothing ran, nothing changed: every part is kept, no engine call
    again = SPLIT.solve(task, previous=first.remaining(set()))
    assert again.stats.reused == 4 and again.stats.part_solves == 0
    assert [s.ground for s in again.steps] == [s.ground for s in first.steps]
    # r3's drive failed and is banned: r3's part is planned again (a detour, which the
    # robots waiting at the depot beside it may share: r4's part is coupled to it), the
    # parts planned before it are kept as they were
    drive = next(s for s in first.steps if s.agent == "r3" and s.skill == "navigate")
    banned = exclude_steps(task, [("r3", "navigate", drive.params)])
    replan = SPLIT.solve(banned, previous=first.remaining(set()))
    assert replan.stats.reused >= 2 and replan.stats.part_solves >= 1
    assert valid(replan) and drive.ground not in {s.ground for s in replan.steps}
    kept = {s.ground for s in first.steps if s.agent in ("r1", "r2")}
    assert kept <= {s.ground for s in replan.steps}
    # steps that ran are not run again: r1's first step done, the rest of its part is kept
    done = first.steps[0]
    assert done.agent == "r1"
    after = msgspec.structs.replace(task, init=replay_state(task, [done]))
    rest = SPLIT.solve(after, previous=first.remaining({done.ground}))
    assert rest.stats.reused == 4 and done.ground not in {s.ground for s in rest.steps}


def replay_state(task: PlanningTask, steps: list[PlanStep]) -> frozenset[GroundFact]:
    state = State(task.init)
    for s in steps:
        apply(task, s.ground, state)
    return frozenset(state.facts)


def test_long_planning_tells_how_many_parts_are_planned(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(planner_module, "PROGRESS_EVERY", 0.0)  # every part, not every second
    fleet = fleet_scene(12)
    told: list[tuple[int, int]] = []
    SPLIT.solve(
        task_of(fleet, str(one_gear_each(fleet))), progress=lambda d, n: told.append((d, n))
    )
    assert told[0] == (1, 12) and all(n == 12 for _, n in told)
    assert [d for d, _ in told] == sorted({d for d, _ in told})  # rising, each count once
    assert told[-1][0] >= 11  # the last is reported when its part is planned, before the end
