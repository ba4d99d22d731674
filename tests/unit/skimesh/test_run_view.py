"""``skimesh run``'s output: a line per change into a pipe (no repeats), a view in place on a
terminal showing the state, step, completion and time."""

from __future__ import annotations

import io

import pytest
from rich.console import Console

from skill_agent.protocol import Progress, RunResult
from skimesh.commands._run_view import RunLines, RunView


def progress(
    seq: int, message: str, fraction: float = -1.0, state: str = "executing", step: str = "execute"
) -> Progress:
    return Progress(
        run_id="run-1", agent="r1", skill="navigate", seq=seq, state=state,  # type: ignore[arg-type]
        message=message, fraction=fraction, step=step,
    )  # fmt: skip


RESULT = RunResult(
    run_id="run-1", agent="r1", skill="navigate", seq=9, success=True, reason="ok",
    message="at Station-1",
)  # fmt: skip


def test_into_a_pipe_a_line_per_change_and_no_repeats(capsys: pytest.CaptureFixture[str]) -> None:
    lines = RunLines()
    lines(progress(0, "", state="pre_sense", step="pre_sense"))
    lines(progress(0, ""))
    for i, fraction in enumerate((0.1, 0.2, 0.3)):
        lines(progress(i, "driving to Station-1", fraction))
    lines(progress(4, "turning"))
    lines(RESULT)
    out = capsys.readouterr().out.splitlines()
    assert out == [
        "  [pre_sense]",
        "  [executing] execute",
        "  [executing] execute: driving to Station-1 (10%)",
        "  [executing] execute: turning",
        "navigate run-1 succeeded: at Station-1",
    ]


def test_the_terminal_view_shows_state_step_completion_and_time() -> None:
    now = [100.0]
    view = RunView("r1", "navigate", clock=lambda: now[0])
    view.take(progress(1, "driving to Station-1", 0.5))
    now[0] += 3.0
    console = Console(file=io.StringIO(), width=160, color_system=None)
    console.print(view.render())
    text = console.file.getvalue()  # type: ignore[attr-defined]
    assert "executing" in text and "driving to Station-1" in text and "run-1" in text
    assert "##########.........." in text and "50%" in text and "3.0 s" in text
    view.take(RESULT)
    console = Console(file=io.StringIO(), width=160, color_system=None)
    console.print(view.render())
    assert "succeeded" in console.file.getvalue()  # type: ignore[attr-defined]
