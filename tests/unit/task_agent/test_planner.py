"""Planning through unified-planning with Kairos and Fast Downward: plans, validation,
unsolvable goals with reasons, time-outs, PDDL output, compression, the async wrapper."""

from __future__ import annotations

import threading
from pathlib import Path

import msgspec
import pytest
from unified_planning.engines import ValidationResultStatus
from unified_planning.engines.plan_validator import SequentialPlanValidator
from unified_planning.environment import Environment, get_environment
from unified_planning.io import PDDLReader
from unified_planning.model import Problem
from up_kairos import KairosValidator

from task_agent import Goal, PlannerTimeoutError, UnsolvableError, parse_goal
from task_agent.discovery import agents_from_view
from task_agent.domain import PlanningTask, build_task
from task_agent.planning import Engine, Plan, Planner, to_unified_planning, to_up_plan
from task_agent.planning import _planner as planner_module
from tests.assets.planning import (
    NAVIGATE,
    OPEN_DOOR,
    PICK,
    PLACE,
    TAKE_OUT,
    KittingScene,
    add_microwave,
    kitting_scene,
)
from tests.conftest import SlowSteps

ENGINES: list[Engine] = ["kairos", "fast-downward"]


def kitting_task(
    robots: int = 2, parts: int = 8, per_robot: int = 2
) -> tuple[KittingScene, PlanningTask]:
    """Fill each robot's kit with ``per_robot`` parts, taken alternately from both stations."""
    scene = kitting_scene(robots, parts)
    wanted = [
        f"contain({scene.kits[i % robots]}, {p})"
        for i, p in enumerate(scene.parts[: robots * per_robot])
    ]
    goal = parse_goal(" and ".join(wanted), scene.view)
    return scene, build_task(agents_from_view(scene.view), scene.view, goal)


def oven_task(*, can_open: bool) -> tuple[KittingScene, PlanningTask]:
    """A gear inside a closed microwave; with ``can_open`` its agent can open the door."""
    scene = kitting_scene(2, 4, skills=(NAVIGATE, PICK, PLACE, TAKE_OUT))
    _, gear = add_microwave(scene, door_open=False, skills=(OPEN_DOOR,) if can_open else ())
    goal = parse_goal(f"contain(KitBox-1, {gear}) and contain(KitBox-2, Gear-2)", scene.view)
    return scene, build_task(agents_from_view(scene.view), scene.view, goal)


@pytest.fixture(scope="module")
def kitting() -> tuple[KittingScene, PlanningTask]:
    return kitting_task()


def validate_with_unified_planning(task: PlanningTask, plan: Plan) -> None:
    """UP's SequentialPlanValidator on the full task. It must run in UP's global environment:
    its grounder creates actions without passing the problem's environment (UP 1.3)."""
    problem = to_unified_planning(task, get_environment())
    result = SequentialPlanValidator(environment=get_environment()).validate(
        problem, to_up_plan(problem, plan.steps)
    )
    assert result.status == ValidationResultStatus.VALID, result


@pytest.mark.parametrize("engine", ENGINES)
def test_kitting_plan_is_valid_and_uses_both_robots(
    kitting: tuple[KittingScene, PlanningTask], engine: Engine
) -> None:
    scene, task = kitting
    plan = Planner(engine=engine).solve(task)
    validate_with_unified_planning(task, plan)
    problem = to_unified_planning(task)  # a private environment: Kairos' validator works there
    with KairosValidator() as validator:
        assert (
            validator.validate(problem, to_up_plan(problem, plan.steps)).status
            == ValidationResultStatus.VALID
        )
    assert {s.agent for s in plan.steps} == {"r1", "r2"}
    for step in plan.steps:
        robot = scene.robots[int(step.agent[1:]) - 1]
        assert step.action == f"{step.skill}__{step.agent}"
        assert step.params["robot"] == robot
        if step.skill in ("pick", "place"):
            assert step.params["gripper"] == f"Gripper-{step.agent[1:]}"
            assert step.params["object"].startswith("Gear-")
    assert [s.index for s in plan.steps] == list(range(len(plan.steps)))
    assert plan.duration == sum(s.duration for s in plan.steps)
    assert plan.stats.engine == engine
    assert plan.stats.objects_solved < plan.stats.objects  # compressed
    assert str(plan).startswith("  1. r")


def test_engines_agree_on_solvability() -> None:
    for can_open in (True, False):
        _, task = oven_task(can_open=can_open)
        outcomes = []
        for engine in ENGINES:
            try:
                plan = Planner(engine=engine).solve(task)
                validate_with_unified_planning(task, plan)
                outcomes.append("solved")
            except UnsolvableError:
                outcomes.append("unsolvable")
        assert outcomes == ["solved" if can_open else "unsolvable"] * 2


def test_unsolvable_goal_names_the_unreachable_fact_and_why() -> None:
    _, task = oven_task(can_open=False)
    with pytest.raises(UnsolvableError) as info:
        Planner().solve(task)
    error = info.value
    assert error.proven
    assert error.unreachable == ("contain(KitBox-1, Gear-5)",)
    assert (
        "contain(KitBox-1, Gear-5) is unreachable: place__r1 needs contain(Gripper-1, Gear-5)"
        in error.reason
    )
    assert (
        "take_out__r1 needs doorOpen=true(?appliance), which no skill's post-condition makes true"
        in error.reason
    )


def test_goal_nothing_can_achieve() -> None:
    scene = kitting_scene(1, 2)
    goal = parse_goal("not contain(Station-1, PartBox-1) and available(Gear-1) = true", scene.view)
    task = build_task(agents_from_view(scene.view), scene.view, goal)
    with pytest.raises(UnsolvableError) as info:
        Planner().solve(task)
    assert info.value.unreachable == ("not contain(Station-1, PartBox-1)", "available=true(Gear-1)")
    assert "no skill's post-condition undoes it" in info.value.reason


@pytest.mark.parametrize("engine", ENGINES)
def test_timeout(engine: Engine) -> None:
    _, task = kitting_task(5, 40, per_robot=8)
    whole = f"{engine} found no plan for the whole task within 0.001 s"
    with pytest.raises(PlannerTimeoutError, match=whole) as info:
        Planner(engine=engine, timeout=0.001, decompose=False).solve(task)
    assert info.value.timeout == 0.001
    by_parts = r"planning by parts planned 0 of 5 goal parts in time \(0.001 s for"
    with pytest.raises(PlannerTimeoutError, match=by_parts):
        Planner(engine=engine, timeout=0.001).solve(task)


def test_concurrent_fast_downward_solves_do_not_mix(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Fast Downward's translator file goes to each solve's own directory, not the caller's
    working directory (where concurrent solves overwrote each other's)."""
    monkeypatch.chdir(tmp_path)
    tasks = [kitting_task(2, 4)[1], kitting_task(3, 6, per_robot=2)[1]] * 2
    results: list[Plan | BaseException] = []

    def solve(task: PlanningTask) -> None:
        try:
            for _ in range(2):
                results.append(Planner(engine="fast-downward").solve(task))
        except BaseException as exc:  # reported below
            results.append(exc)

    threads = [threading.Thread(target=solve, args=(task,)) for task in tasks]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(timeout=120)
    assert all(isinstance(r, Plan) for r in results), results
    assert len(results) == 8
    assert list(tmp_path.iterdir()) == []


def test_fallback_to_the_full_task_when_compression_drops_too_much(
    kitting: tuple[KittingScene, PlanningTask], monkeypatch: pytest.MonkeyPatch
) -> None:
    _, task = kitting
    # Keep too little: the stations are gone, nobody can drive to the parts.
    monkeypatch.setattr(
        planner_module,
        "relevant_objects",
        lambda t: {o for o in t.objects if not o.startswith("Station")},
    )
    plan = Planner(decompose=False).solve(task)
    assert plan.stats.fallback
    assert plan.stats.objects_solved == plan.stats.objects


def test_no_compression(kitting: tuple[KittingScene, PlanningTask]) -> None:
    _, task = kitting
    plan = Planner(compress=False, decompose=False).solve(task)
    assert plan.stats.objects_solved == plan.stats.objects and not plan.stats.fallback


def test_problem_kind_matches_unified_planning(kitting: tuple[KittingScene, PlanningTask]) -> None:
    _, plain = kitting
    _, oven = oven_task(can_open=True)
    scene = kitting_scene(1, 1)
    grab = msgspec.structs.replace(PICK, name="grab", pre=[], hold=[])
    loose = build_task(
        agents_from_view(kitting_scene(1, 1, skills=(grab,)).view),
        scene.view,
        parse_goal("not contain(PartBox-1, Gear-1)", scene.view),
    )
    for task in (plain, oven, loose):
        problem = to_unified_planning(task)
        assert problem.kind == Problem.kind.fget(problem)
    assert to_unified_planning(loose).kind.has_forall_effects()


# unified-planning 1.3's PDDL reader calls pyparsing APIs that pyparsing 3.3 deprecates
@pytest.mark.filterwarnings("ignore::DeprecationWarning:unified_planning.io.pddl_reader")
def test_emit_pddl_reads_back(kitting: tuple[KittingScene, PlanningTask], tmp_path: Path) -> None:
    _, task = kitting
    planner = Planner()
    domain, problem = planner.emit_pddl(task, tmp_path / "full")
    text = domain.read_text()
    assert "(:action pick__r1" in text and "(:action pick__r2" in text
    assert "(not (exists (?w - thing)" in text
    assert "(contain partbox-1 gear-1)" in problem.read_text()
    parsed = PDDLReader(Environment()).parse_problem(str(domain), str(problem))
    assert len(parsed.actions) == len(task.actions)
    assert len(parsed.all_objects) == len(task.objects)
    _, small = planner.emit_pddl(task, tmp_path / "small", compressed=True)
    assert "gear-8" not in small.read_text()


def test_unknown_engine() -> None:
    with pytest.raises(ValueError, match="unknown engine 'tamer'"):
        Planner(engine="tamer")  # type: ignore[arg-type]


@pytest.fixture
def scene_and_goal() -> tuple[KittingScene, Goal]:
    scene = kitting_scene(2, 8)
    return scene, parse_goal("contain(KitBox-1, Gear-1) and contain(KitBox-2, Gear-2)", scene.view)


@pytest.mark.anyio
async def test_async_plan_runs_off_the_loop(
    scene_and_goal: tuple[KittingScene, Goal], blocking_detector: SlowSteps
) -> None:
    scene, goal = scene_and_goal
    agents = agents_from_view(scene.view)
    planner = Planner()
    plan = await planner.plan(agents, scene.view, goal)
    again = await planner.plan(agents, scene.view, goal)
    assert plan.steps and len(again.steps) == len(plan.steps)
    assert not blocking_detector.reports
    assert len(planner.plan_sync(agents, scene.view, goal).steps) == len(plan.steps)
