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
