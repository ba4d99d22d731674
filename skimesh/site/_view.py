"""What ``skimesh up`` and ``skimesh status`` show: a live table on a terminal (rich), lines
otherwise (one per change of a component's state)."""

from __future__ import annotations

import sys
from collections.abc import Sequence
from typing import TextIO

from rich.console import Console
from rich.live import Live
from rich.table import Table

from ._state import Row

__all__ = ["LineView", "LiveView", "row_line", "table"]

_STYLE = {"ready": "green", "failed": "bold red", "unreachable": "red", "restarting": "yellow"}


def row_line(row: Row) -> str:
    pid = f" (pid {row.pid})" if row.pid and row.state not in ("stopped", "pending") else ""
    detail = f": {row.detail}" if row.detail else ""
    return f"{row.name} on {row.host} {row.state}{pid}{detail}"


def table(rows: Sequence[Row]) -> Table:
    out = Table("COMPONENT", "HOST", "STATE", "PID", "RESTARTS", "DETAIL", box=None)
    for row in rows:
        style = _STYLE.get(row.state, "")
        out.add_row(
            row.name,
            row.host,
            f"[{style}]{row.state}[/]" if style else row.state,
            str(row.pid or ""),
            str(row.restarts),
            row.detail,
        )
    return out


class LineView:
    """A line on ``stream`` whenever a component's state changes, and each message."""

    def __init__(self, stream: TextIO | None = None) -> None:
        self.stream = stream or sys.stderr
        self._last: dict[str, tuple[str, str]] = {}

    def __call__(self, rows: list[Row], message: str) -> None:
        for row in rows:
            now = (row.state, row.detail if row.state != "starting" else "")
            if self._last.get(row.name) != now and row.state != "pending":
                self._last[row.name] = now
                print(f"skimesh up: {row_line(row)}", file=self.stream, flush=True)
        if message:
            print(f"skimesh up: {message}", file=self.stream, flush=True)


class LiveView:
    """A rich live table on the terminal; messages print above it."""

    def __init__(self) -> None:
        self.console = Console(stderr=True)
        self.live = Live(console=self.console, auto_refresh=False, transient=False)

    def __enter__(self) -> LiveView:
        self.live.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.live.stop()

    def __call__(self, rows: list[Row], message: str) -> None:
        if message:
            self.console.print(f"skimesh up: {message}")
        self.live.update(table(rows), refresh=True)
