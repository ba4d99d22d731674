"""What the demo prints: one line per step event (progress only when its message changes, not
the agent's "holds devices" lines), the plan as a table with its partial order, and a summary
that says whether the goal holds in the world model and in the physics."""

from __future__ import annotations

import re

from skimesh.demo import MissionResult, MissionView, goal_holds, summary_lines
from task_agent.protocol import (
    FactCheck,
    Planned,
    PlannedStep,
    Replanning,
    StepFinished,
    StepProgress,
    StepStarted,
    TaskEvent,
    TaskFinished,
    TaskStarted,
)

T, AT = "t-1", 0.0


def progress(seq: int, state: str, message: str, fraction: float = -1.0) -> StepProgress:
    return StepProgress(
        task_id=T,
        seq=seq,
        stamp=AT,
        step=0,
        agent="r1",
        state=state,
        message=message,
        fraction=fraction,
    )


def finished(seq: int, step: int, agent: str, ok: bool) -> StepFinished:
    return StepFinished(
        task_id=T,
        seq=seq,
        stamp=AT,
        step=step,
        agent=agent,
        skill="pick",
        success=ok,
        reason="" if ok else "execution",
        message="" if ok else "grasp failed",
    )


def events() -> list[TaskEvent]:
    steps = [
        PlannedStep(index=0, agent="r1", skill="pick", params={"object": "Gear-1"}, finish=4.0),
        PlannedStep(
            index=1,
            agent="r2",
            skill="pick",
            params={"object": "Bolt-1"},
            after=[0],
            start=4.0,
            finish=8.0,
        ),
    ]
    started = [
        StepStarted(task_id=T, seq=3 + i, stamp=AT, step=i, agent=a, skill="pick", run_id=a)
        for i, a in enumerate(("r1", "r2"))
    ]
    return [
        TaskStarted(task_id=T, seq=1, stamp=AT, goal="contain(KitBox-1, Gear-1)"),
        Planned(
            task_id=T,
            seq=2,
            stamp=AT,
            steps=steps,
            planner="kairos",
            plan_seconds=0.25,
            makespan=8.0,
            sequential=8.0,
        ),
        *started,
        progress(5, "pending", "holds devices: Arm-1"),
        progress(6, "executing", "approaching Gear-1", 0.1),
        progress(7, "executing", "approaching Gear-1", 0.2),
        progress(8, "executing", "closing on Gear-1", 0.6),
        finished(9, 0, "r1", True),
        finished(10, 1, "r2", False),
        Replanning(task_id=T, seq=11, stamp=AT, attempt=1, reason="step 1 failed"),
        TaskFinished(task_id=T, seq=12, stamp=AT, outcome="succeeded", steps_run=2, replans=1),
    ]


def run_view() -> tuple[MissionView, list[str]]:
    lines: list[str] = []
    clock = iter(float(t) for t in range(0, 100, 2))
    view = MissionView(sim_clock=lambda: next(clock), out=lines.append)
    for event in events():
        view(event)
    return view, lines


def test_one_line_per_step_event() -> None:
    view, lines = run_view()
    timed = re.compile(r"^ *\d+\.\ds +\d+\.\ds  (.*)$")  # wall and simulated seconds
    body = [m.group(1) for line in lines if (m := timed.match(line))]
    assert body == [
        "task t-1 started: contain(KitBox-1, Gear-1)",
        "plan ready",
        "r1         #0   pick() started",
        "r2         #1   pick() started",
        "r1         #0   pick: approaching Gear-1",
        "r1         #0   pick: closing on Gear-1",
        "r1         #0   pick done (12.0 s)",
        "r2         #1   pick FAILED (execution) (12.0 s): grasp failed",
        "replanning (attempt 1): step 1 failed",
        "task t-1 succeeded",
    ]
    assert lines[0].startswith("    0.0s     0.0s  task")
    table = [line for line in lines if not timed.match(line)]
    assert table[0] == (
        "    plan 0 by kairos in 0.25 s: 2 steps on r1, r2; estimated makespan 8.0 s in "
        "parallel, 8.0 s one step at a time"
    )
    assert table[3].split() == ["1", "r2", "pick(object=Bolt-1)", "0", "4.0-", "8.0", "s"]
    assert view.robots["r2"].failed == 1 and view.robots["r1"].busy == 12.0
    assert view.sim_makespan == 22.0


def test_the_summary_says_where_the_goal_holds() -> None:
    view, _ = run_view()
    checks = [
        FactCheck("contain(KitBox-1, Gear-1)", True, True, "Gear-1 lies in KitBox-1"),
        FactCheck("heated(MealBox-1) = true", True, None, "world model only"),
    ]
    result = MissionResult(finished=view.finished, checks=checks, interrupted=False)
    assert result.goal_reached
    lines = summary_lines(result, view, recording="/tmp/run.rrd")
    assert lines[0] == "== GOAL REACHED"
    assert lines[1] == "   facts: 2/2 hold in the world model, 1/1 in the physics"
    assert "task t-1 succeeded: 2 steps run, 1 replan" in lines[4]
    assert lines[-1] == "   recording: /tmp/run.rrd"
    moved = FactCheck("contain(KitBox-1, Gear-1)", True, False, "Gear-1 does not lie in KitBox-1")
    assert not goal_holds([moved]) and not goal_holds([])
    bad = MissionResult(finished=view.finished, checks=[moved], interrupted=False)
    assert not bad.goal_reached
    assert summary_lines(bad, view, recording="x")[0] == "== GOAL NOT REACHED"
