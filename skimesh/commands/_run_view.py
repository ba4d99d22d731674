"""What ``skimesh run`` shows while a skill runs: one line per change into a pipe, one view
updated in place on a terminal.

- :class:`RunLines` prints a line when the run's state, step or message changes (a progress
  report that only moves the completion is no new line), then the result.
- :class:`RunView` is the terminal view: agent, skill, run, state, step, message, completion
  bar and time since the start, redrawn in place by ``rich.live.Live``
  (:func:`follow_run`), then the result as one line.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Awaitable, Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from skill_agent.protocol import Progress, RunEvent, RunResult

if TYPE_CHECKING:  # rich loads when the view is shown
    from rich.console import RenderableType

__all__ = ["RunLines", "RunView", "follow_run", "result_line", "with_output"]

_BAR = 20


def result_line(result: RunResult) -> str:
    status = "succeeded" if result.success else f"failed ({result.reason})"
    return f"{result.skill} {result.run_id} {status}: {result.message}".rstrip()


def _progress_line(event: Progress) -> str:
    """``  [executing] drive: driving to Station-1 (40%)``; a step named as its state, or
    without a message, says no more than it has."""
    done = f" ({event.fraction:.0%})" if event.fraction >= 0 else ""
    step = "" if event.step in ("", event.state) else f" {event.step}"
    said = f"{step}: {event.message}" if step and event.message else f"{step} {event.message}"
    return f"  [{event.state}]{said.rstrip()}{done}"


@dataclass
class RunLines:
    """The pipe's output: a line per change, never the same text twice in a row."""

    _last: tuple[str, str, str] | None = None

    def __call__(self, event: RunEvent) -> None:
        if isinstance(event, RunResult):
            print(result_line(event), flush=True)
            return
        key = (event.state, event.step, event.message)
        if key != self._last:
            self._last = key
            print(_progress_line(event), flush=True)


@dataclass
class RunView:
    """The terminal view of one run (see the module doc)."""

    agent: str
    skill: str
    clock: Callable[[], float] = time.monotonic
    run_id: str = ""
    state: str = "starting"
    step: str = ""
    message: str = ""
    fraction: float = -1.0
    started: float = field(default=-1.0)

    def __post_init__(self) -> None:
        self.started = self.clock()

    def take(self, event: RunEvent) -> None:
        self.run_id = event.run_id
        if isinstance(event, RunResult):
            self.state = "succeeded" if event.success else f"failed ({event.reason})"
            self.message = event.message
            return
        self.state, self.step, self.message = event.state, event.step, event.message
        if event.fraction >= 0:
            self.fraction = event.fraction

    def render(self) -> RenderableType:
        from rich import box
        from rich.table import Table

        table = Table(box=box.SIMPLE_HEAD, pad_edge=False, show_edge=False)
        for name in ("AGENT", "SKILL", "RUN", "STATE", "STEP", "DONE", "TIME", "MESSAGE"):
            table.add_column(name, overflow="fold")
        if self.fraction >= 0:
            filled = round(self.fraction * _BAR)
            done = f"{'#' * filled}{'.' * (_BAR - filled)} {self.fraction:4.0%}"
        else:
            done = "-"
        elapsed = f"{self.clock() - self.started:6.1f} s"
        table.add_row(
            self.agent, self.skill, self.run_id, self.state, self.step, done, elapsed, self.message
        )
        return table


@contextmanager
def follow_run(view: RunView) -> Iterator[Callable[[RunEvent], None]]:
    """Show ``view`` in place on stdout while the block runs; yields the ``on_event`` callback
    that feeds it. The last state stays on the screen, then the result's line follows."""
    from rich.live import Live

    with Live(get_renderable=view.render, refresh_per_second=8, transient=False) as live:

        def on_event(event: RunEvent) -> None:
            view.take(event)
            live.refresh()

        yield on_event


async def with_output(
    run: Callable[[Callable[[RunEvent], None]], Awaitable[RunResult]],
    *,
    agent: str,
    skill: str,
    json_out: Callable[[RunEvent], None] | None,
) -> RunResult:
    """Run ``run(on_event)`` with the right output: JSON lines, the live view on a terminal,
    or :class:`RunLines`; the result line ends the live view."""
    if json_out is not None:
        return await run(json_out)
    if not sys.stdout.isatty():
        return await run(RunLines())
    with follow_run(RunView(agent, skill)) as on_event:
        result = await run(on_event)
    print(result_line(result), flush=True)
    return result
