"""What ``skimesh task submit`` prints for a plan: elements by their display names (the label,
with the id where the two differ), as the task agent names them in the ``Planned`` event."""

from __future__ import annotations

from skimesh.commands._task_output import ProgressPrinter
from task_agent.protocol import Planned, PlannedStep, StepProgress
from wm_store.protocol import Value


def test_plan_rows_name_elements_by_label_and_id() -> None:
    step = PlannedStep(
        index=0,
        agent="r1",
        skill="pick",
        params={"object": "Gear-1", "holder": "PartBox-1", "width": 0.04},
    )
    event = Planned(
        task_id="t",
        seq=2,
        stamp=0.0,
        steps=[step],
        names={"Gear-1": "Pulley-4 (Gear-1)", "PartBox-1": "PartBox-1"},
    )
    head, row = ProgressPrinter().lines(event)
    assert "1 step on r1" in head
    assert "pick(object=Pulley-4 (Gear-1), holder=PartBox-1, width=0.04)" in row
    # An older task agent sends no names: the ids are printed as they are.
    bare = Planned(task_id="t", seq=2, stamp=0.0, steps=[step])
    assert "pick(object=Gear-1, holder=PartBox-1" in ProgressPrinter().lines(bare)[1]


def test_progress_prints_a_line_when_the_text_changes_not_at_every_update() -> None:
    printer = ProgressPrinter()

    def progress(seq: int, message: str, fraction: float) -> StepProgress:
        return StepProgress(
            task_id="t", seq=seq, stamp=float(seq), step=1, agent="r1", state="executing",
            message=message, fraction=fraction,
        )  # fmt: skip

    lines = [
        line
        for i, (message, fraction) in enumerate(
            [("driving to Station-1", f / 10) for f in range(10)] + [("at Station-1", 1.0)]
        )
        for line in printer.lines(progress(i + 1, message, fraction))
    ]
    assert len(lines) == 2, lines
    assert "driving to Station-1" in lines[0] and "at Station-1" in lines[1]


def test_the_live_view_shows_robots_and_the_plan_as_the_task_goes() -> None:
    import io

    from rich.console import Console

    from skimesh.commands._live import TaskView
    from task_agent.protocol import StepFinished, StepStarted, TaskEvent, TaskStarted

    view = TaskView()
    events: list[TaskEvent] = [
        TaskStarted(task_id="t-1", seq=1, stamp=100.0, goal="contain(KitBox-1, Gear-1)"),
        Planned(
            task_id="t-1",
            seq=2,
            stamp=100.1,
            steps=[
                PlannedStep(index=0, agent="r1", skill="navigate", params={"goal": "Station-1"}),
                PlannedStep(
                    index=1, agent="r1", skill="pick", params={"object": "Gear-1"}, after=[0]
                ),
            ],
            names={"Gear-1": "big gear (Gear-1)"},
        ),
        StepStarted(
            task_id="t-1", seq=3, stamp=100.2, step=0, agent="r1", skill="navigate", run_id="a"
        ),
        StepProgress(
            task_id="t-1",
            seq=4,
            stamp=101.0,
            step=0,
            agent="r1",
            state="executing",
            message="driving to Station-1",
            fraction=0.5,
        ),
    ]
    for event in events:
        view.apply(event)
    out = io.StringIO()
    Console(file=out, width=120, force_terminal=False, color_system=None).print(
        view.render(now=102.0)
    )
    text = out.getvalue()
    assert "task t-1: contain(KitBox-1, Gear-1)  (2.0 s)" in text
    assert "executing driving to Station-1" in text and "50%" in text
    assert "pick(object=big gear (Gear-1))" in text
    rows = {line.split("│")[1].strip(): line for line in text.splitlines() if "│" in line}
    assert "running" in rows["0"] and "waiting" in rows["1"]
    view.apply(StepFinished(task_id="t-1", seq=5, stamp=103.0, step=0, agent="r1",
                            skill="navigate", success=True, reason="succeeded"))  # fmt: skip
    assert view.plan[0].status == "done" and view.robots["r1"].phase == "done"
    # A robot whose step ended shows that step done, its time stopped at the step's end.
    out = io.StringIO()
    Console(file=out, width=120, force_terminal=False, color_system=None).print(
        view.render(now=130.0)
    )
    robot_row = next(line for line in out.getvalue().splitlines() if line.startswith("│ r1"))
    assert "navigate" in robot_row and "done" in robot_row and "100%" in robot_row
    assert "2.8 s" in robot_row and "driving" not in robot_row


def test_the_live_view_keeps_the_rows_that_matter_when_not_all_fit() -> None:
    import io

    from rich.console import Console

    from skimesh.commands._live import TaskView
    from task_agent.protocol import StepFinished, StepStarted, TaskStarted

    view = TaskView()
    view.apply(TaskStarted(task_id="t-1", seq=1, stamp=0.0, goal="g"))
    steps = [PlannedStep(index=i, agent=f"r{i % 20}", skill="pick", params={}) for i in range(60)]
    view.apply(Planned(task_id="t-1", seq=2, stamp=0.0, steps=steps))
    seq = 3
    for i in range(50):  # steps 40..49 run (on r0..r9), 50..59 wait, step 7 failed
        agent = f"r{i % 20}"
        view.apply(StepStarted(task_id="t-1", seq=seq, stamp=1.0, step=i, agent=agent,
                               skill="pick", run_id=str(i)))  # fmt: skip
        if i < 40:
            view.apply(StepFinished(task_id="t-1", seq=seq + 1, stamp=2.0, step=i, agent=agent,
                                    skill="pick", success=i != 7, reason="slipped"))  # fmt: skip
        seq += 2
    out = io.StringIO()
    Console(file=out, width=100, force_terminal=False, color_system=None).print(
        view.render(now=4.0, height=60)
    )
    text = out.getvalue()
    assert len(text.splitlines()) <= 60, text
    robots_part, plan_part = text.split("\nplan")
    robot_rows = [line.split("│")[1].strip() for line in robots_part.splitlines() if "│" in line]
    plan_rows = [line.split("│")[5].strip() for line in plan_part.splitlines() if "│" in line]
    # The robots in a step first, in natural order (r2 before r10); the plan's failed and
    # running steps, then the next waiting ones; no step done.
    assert robot_rows == [f"r{i}" for i in range(len(robot_rows))], robot_rows
    assert plan_rows[:11] == ["FAILED"] + ["running"] * 10 and "waiting" in plan_rows
    assert "done" not in plan_rows
    assert "robots not shown" in text and "steps not shown: 39 done" in text
    # Everything fits without a height: 60 plan rows.
    out = io.StringIO()
    Console(file=out, width=100, force_terminal=False, color_system=None).print(
        view.render(now=4.0)
    )
    assert "not shown" not in out.getvalue()


def test_the_live_view_fits_a_short_terminal_where_calls_wrap() -> None:
    """Given the terminal's size, as many plan rows as fit its height at its width (a long
    call takes several lines), the count of the others below; everything where it fits."""
    import io

    from rich.console import Console

    from skimesh.commands._live import TaskView
    from task_agent.protocol import StepStarted, TaskStarted

    view = TaskView()
    view.apply(TaskStarted(task_id="t-1", seq=1, stamp=0.0, goal="g"))
    params: dict[str, Value] = {f"parameter_{k}": f"Element-{k}" for k in range(8)}  # wraps
    steps = [PlannedStep(index=i, agent="r1", skill="pick", params=params) for i in range(10)]
    view.apply(Planned(task_id="t-1", seq=2, stamp=0.0, steps=steps))
    view.apply(StepStarted(task_id="t-1", seq=3, stamp=1.0, step=0, agent="r1", skill="pick",
                           run_id="a"))  # fmt: skip
    for height, shown in ((30, False), (200, True)):
        out = io.StringIO()
        console = Console(file=out, width=80, height=height, color_system=None)
        console.print(view.render(now=2.0, height=height, width=80))
        text = out.getvalue()
        assert len(text.splitlines()) <= height, text
        assert ("steps not shown" not in text) == shown, text
        assert "running" in text


def test_pause_and_resume_are_shown_in_lines_and_in_the_live_view() -> None:
    import io

    from rich.console import Console

    from skimesh.commands._live import TaskView
    from task_agent.protocol import TaskPaused, TaskResumed, TaskStarted

    start = TaskStarted(task_id="t-1", seq=1, stamp=100.0, goal="g")
    paused = TaskPaused(task_id="t-1", seq=2, stamp=104.5, reason="coffee", runs=["r1/a"])
    resumed = TaskResumed(task_id="t-1", seq=3, stamp=110.0, runs=["r1/a"])
    printer = ProgressPrinter()
    lines = [line for e in (start, paused, resumed) for line in printer.lines(e)]
    assert lines[1] == "   4.50s  paused (coffee): no new step starts; runs paused: r1/a"
    assert lines[2] == "  10.00s  resumed; runs resumed: r1/a"
    view = TaskView()
    for event in (start, paused):
        view.apply(event)
    out = io.StringIO()
    console = Console(file=out, width=120, force_terminal=False, color_system=None)
    console.print(view.render(now=105.0))
    assert "task t-1: g  (5.0 s)  PAUSED" in out.getvalue()
    view.apply(resumed)
    assert not view.paused and view.note == "resumed; runs resumed: r1/a"
