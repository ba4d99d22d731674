"""Plans as partial orders: causal / threat / resource orderings, schedules, parallel robots,
balancing interchangeable steps between robots."""

from __future__ import annotations

import random

import pytest
from msgspec import json

from skill_agent.protocol import ParamSpec, PropertyCond, SkillDescription
from task_agent import parse_goal
from task_agent.discovery import agents_from_view
from task_agent.domain import PlanningTask, build_task
from task_agent.planning import (
    Engine,
    PartialOrderPlan,
    Plan,
    Planner,
    PlanStats,
    PlanStep,
    to_partial_order,
)
from task_agent.reachability import replay
from tests.assets.planning import apply_ops, kitting_scene
from wm_store import RobotRegistration, SkillSpec, registration_ops

CHECK = SkillDescription(
    name="check",
    doc="Inspect a part and mark it available.",
    parameters=[
        ParamSpec(name="object", type="Part"),
        ParamSpec(name="robot", type="Robot", kind="hardware"),
    ],
    post=[PropertyCond(param="object", property="available", value=True)],
    duration=5.0,
)


def kitting_plan(engine: Engine = "kairos") -> Plan:
    scene = kitting_scene(2, 8)
    goal = parse_goal(
        "contain(KitBox-1, Gear-1) and contain(KitBox-1, Gear-2) and "
        "contain(KitBox-2, Gear-3) and contain(KitBox-2, Gear-4)",
        scene.view,
    )
    return Planner(engine=engine).solve(build_task(agents_from_view(scene.view), scene.view, goal))


def linear_extensions(po: PartialOrderPlan, rng: random.Random, count: int) -> list[list[int]]:
    out = []
    for _ in range(count):
        preds = {i: set(po.predecessors(i)) for i in range(len(po.steps))}
        done: list[int] = []
        while len(done) < len(po.steps):
            ready = [i for i in preds if i not in done and preds[i] <= set(done)]
            done.append(rng.choice(ready))
        out.append(done)
    return out


@pytest.mark.parametrize("engine", ["kairos", "fast-downward"])
def test_two_robots_fill_their_kits_in_parallel(engine: Engine) -> None:
    plan = kitting_plan(engine)
    po = to_partial_order(plan)
    assert po.sequential == pytest.approx(plan.duration)
    assert po.makespan < po.sequential
    assert po.makespan <= 0.6 * po.sequential  # two independent robots: about half
    for e in po.edges:  # independent work: nothing orders one robot after the other
        assert po.steps[e.before].step.agent == po.steps[e.after].step.agent
    for i, s in enumerate(po.steps):
        before = [po.steps[p].finish for p in po.predecessors(i)]
        assert s.start == pytest.approx(max(before, default=0.0))
        assert s.finish == pytest.approx(s.start + s.step.duration)
        assert f"agent {s.step.agent}" in s.resources
    assert po.makespan == max(s.finish for s in po.steps)


def test_every_linear_extension_is_a_valid_plan() -> None:
    plan = kitting_plan()
    po = to_partial_order(plan, balance=False)
    for order in linear_extensions(po, random.Random(7), 25):
        _, problem = replay(plan.task, [po.steps[i].step.ground for i in order])
        assert problem == ""


def test_edges_say_why() -> None:
    plan = kitting_plan()
    po = to_partial_order(plan, balance=False)
    steps = [s.step for s in po.steps]
    for pick in (i for i, s in enumerate(steps) if s.skill == "pick"):
        obj = steps[pick].params["object"]
        place = next(
            i for i, s in enumerate(steps) if s.skill == "place" and s.params["object"] == obj
        )
        reasons = {(e.reason, e.what) for e in po.edges if (e.before, e.after) == (pick, place)}
        assert reasons == {("causal", f"contain({steps[pick].params['gripper']}, {obj})")}
    assert {e.reason for e in po.edges} <= {"causal", "threat", "conflict", "resource"}
    text = po.render()
    assert text.splitlines()[0].startswith(
        f"{len(steps)} steps on 2 agents: makespan {po.makespan:.1f} s"
    )
    assert "r1" in text and "pick(" in text and "after" in text
    dot = po.to_dot()
    assert dot.startswith("digraph plan {") and dot.count("->") == len(po.edges)


def check_task(robots: int, parts: int) -> PlanningTask:
    scene = kitting_scene(robots, parts, skills=(CHECK,))
    goal = parse_goal(" and ".join(f"available({p}) = true" for p in scene.parts), scene.view)
    return build_task(agents_from_view(scene.view), scene.view, goal)


def on_one_robot(task: PlanningTask) -> Plan:
    schema = task.actions["check__r1"]
    parts = sorted(
        (o for o, t in task.objects.items() if t == "Part"), key=lambda o: int(o.split("-")[1])
    )
    steps = tuple(
        PlanStep(
            index=i,
            action=schema.name,
            agent="r1",
            skill="check",
            args=(p,),
            params={**schema.bound, "object": p},
            duration=schema.duration,
        )
        for i, p in enumerate(parts)
    )
    return Plan(steps=steps, task=task, stats=PlanStats(engine="test", objects=0, objects_solved=0))


def test_balancing_moves_interchangeable_steps_to_idle_robots() -> None:
    task = check_task(2, 6)
    plan = on_one_robot(task)
    assert to_partial_order(plan, balance=False).makespan == 30.0
    po = to_partial_order(plan)
    assert po.makespan == 15.0
    assert [s.step.agent for s in po.steps].count("r2") == 3
    assert len(po.moves) == 3 and po.moves[0].endswith(": r2")
    assert [s.step.index for s in po.steps] == list(range(6))
    assert replay(task, [s.step.ground for s in po.steps])[1] == ""
    for s in po.steps:
        assert s.step.params["robot"] == f"MobileManipulator-{s.step.agent[1:]}"
        assert s.step.action == f"check__{s.step.agent}"


def test_balancing_whatever_the_planner_chose() -> None:
    task = check_task(3, 7)
    po = to_partial_order(Planner().solve(task))
    assert po.makespan == 15.0  # 7 checks of 5 s on 3 robots: 3 rounds


def test_a_shared_appliance_orders_steps_of_different_agents() -> None:
    scene = kitting_scene(2, 1, skills=(CHECK,))
    heat = SkillDescription(
        name="heat",
        parameters=[ParamSpec(name="oven", type="Appliance", kind="hardware")],
        post=[PropertyCond(param="oven", property="heating", value=True)],
    )
    inspect = SkillDescription(
        name="inspect",
        parameters=[ParamSpec(name="appliance", type="Appliance")],
        post=[PropertyCond(param="appliance", property="available", value=True)],
    )
    subclasses = {c: scene.view.ontology.subclasses(c) for c in ("Agent", "Robot", "Skill")}
    for reg in (
        RobotRegistration(
            agent="oven-agent",
            agent_type="DeviceAgent",
            robot_type="Microwave",
            robot_label="oven",
            robot_properties={"doorOpen": False, "heating": False},
            skills=[SkillSpec(name="heat", description=json.encode(heat).decode())],
        ),
        RobotRegistration(
            agent="r3",
            robot_type="MobileManipulator",
            robot_label="robot-3",
            skills=[SkillSpec(name="inspect", description=json.encode(inspect).decode())],
        ),
    ):
        apply_ops(scene, registration_ops(scene.view.state, reg, subclasses=subclasses))
    goal = parse_goal("heating(oven) and available(oven) = true", scene.view)
    po = to_partial_order(
        Planner().solve(build_task(agents_from_view(scene.view), scene.view, goal))
    )
    assert {s.step.agent for s in po.steps} == {"oven-agent", "r3"}
    (edge,) = po.edges
    assert (edge.reason, edge.what) == ("resource", "Microwave-1")
    assert po.makespan == 2.0
