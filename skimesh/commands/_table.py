"""Tables on the terminal: :func:`print_table`, the one table printer of the commands.

On a terminal the table is drawn by rich and wraps its widest cells to the terminal's width
(a 330-character skills table becomes readable); into a pipe or a file it is plain columns
separated by two spaces, one row per line, so ``grep`` and ``awk`` keep working. rich is
imported only for a terminal (start-up time).
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from typing import TextIO

__all__ = ["plain_table", "print_table"]


def plain_table(head: Sequence[str], rows: Sequence[Sequence[str]]) -> list[str]:
    """The lines of ``rows`` under ``head``, columns aligned, trailing spaces cut."""
    widths = [max(len(r[i]) for r in (head, *rows)) for i in range(len(head))]
    return [
        "  ".join(c.ljust(w) for c, w in zip(row, widths, strict=True)).rstrip()
        for row in (head, *rows)
    ]


def print_table(
    head: Sequence[str], rows: Sequence[Sequence[str]], *, out: TextIO | None = None
) -> None:
    """Print ``rows`` under ``head`` to ``out`` (stdout): wrapped to the terminal's width on a
    terminal, plain aligned columns otherwise."""
    out = out or sys.stdout
    if not out.isatty():
        for line in plain_table(head, rows):
            print(line, file=out)
        return
    from rich import box
    from rich.console import Console
    from rich.table import Table

    table = Table(box=box.SIMPLE_HEAD, pad_edge=False, show_edge=False)
    for name in head:
        table.add_column(name, overflow="fold")
    for row in rows:
        table.add_row(*row)
    Console(file=out, highlight=False).print(table)
