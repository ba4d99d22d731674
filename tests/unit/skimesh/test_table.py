"""One table printer: plain aligned columns into a pipe, wrapped to the width on a terminal."""

from __future__ import annotations

import io
import re

import pytest

from skimesh.commands._table import plain_table, print_table

ANSI = re.compile(r"\x1b\[[0-9;]*m")
ROWS = [("r1", "pick", "object: Part (element), holder: Container " * 4), ("r2", "place", "x")]


class Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_into_a_pipe_the_columns_are_plain_and_one_row_per_line() -> None:
    out = io.StringIO()
    print_table(("AGENT", "SKILL", "PARAMETERS"), ROWS, out=out)
    lines = out.getvalue().splitlines()
    assert lines == plain_table(("AGENT", "SKILL", "PARAMETERS"), ROWS)
    assert len(lines) == 3 and lines[1].startswith("r1     pick   object: Part")
    assert lines[2] == "r2     place  x"


def test_on_a_terminal_wide_cells_wrap_to_its_width(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("COLUMNS", "60")
    out = Terminal()
    print_table(("AGENT", "SKILL", "PARAMETERS"), ROWS, out=out)
    lines = [ANSI.sub("", line) for line in out.getvalue().splitlines()]  # styles: not text
    assert max(len(line) for line in lines) <= 60
    assert len(lines) > 4, "the long cell took several lines"
    assert "holder: Container" in out.getvalue()
