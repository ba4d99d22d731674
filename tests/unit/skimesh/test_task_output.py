"""What ``skimesh task submit`` prints for a plan: elements by their display names (the label,
with the id where the two differ), as the task agent names them in the ``Planned`` event."""

from __future__ import annotations

from skimesh.commands._task_output import ProgressPrinter
from task_agent.protocol import Planned, PlannedStep, StepProgress


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
    assert "1 steps on r1" in head
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
    assert view.plan[0].status == "done" and view.robots["r1"].phase == "idle"


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
