"""The estimated against the actual makespan, as `task submit` / `watch` end and `task status`
shows a task."""

from __future__ import annotations

from skimesh.commands._task_output import ProgressPrinter, info_lines
from task_agent.protocol import StepFinished, StepStarted, TaskFinished, TaskInfo


def test_the_summary_gives_estimate_actual_error_and_balance() -> None:
    printer = ProgressPrinter()
    lines = []
    for agent, step, t0, t1 in (("r1", 0, 1.0, 4.0), ("r2", 1, 1.0, 2.0)):
        lines += printer.lines(
            StepStarted(task_id="t", seq=1, stamp=t0, step=step, agent=agent, skill="pick",
                        run_id=f"x{step}")
        )  # fmt: skip
        lines += printer.lines(
            StepFinished(task_id="t", seq=2, stamp=t1, step=step, agent=agent, skill="pick",
                         success=True, reason="ok")
        )  # fmt: skip
    end = TaskFinished(
        task_id="t", seq=5, stamp=5.0, outcome="succeeded", duration=4.0,
        estimated_makespan=3.6, actual_makespan=4.0,
    )  # fmt: skip
    text = "\n".join(printer.lines(end))
    assert "makespan: estimated 3.6 s, actual 4.0 s (error -10%)" in text
    assert "balance: busy 2.0 s per robot on average (2 robots) in a makespan of 4.0 s" in text


def test_status_shows_the_estimate_while_running_and_both_once_ended() -> None:
    running = TaskInfo(task_id="t", outcome="running", estimated_makespan=12.0)
    assert "  makespan: estimated 12.0 s" in info_lines(running)
    ended = TaskInfo(
        task_id="t", outcome="succeeded", estimated_makespan=12.0, actual_makespan=10.0
    )
    assert "  makespan: estimated 12.0 s, actual 10.0 s (error +20%)" in info_lines(ended)
    assert not any(
        "makespan" in line for line in info_lines(TaskInfo(task_id="t", outcome="failed"))
    )
