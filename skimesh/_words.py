"""Counted nouns in what skimesh prints for people: ``counted(1, "step")`` is ``1 step``,
``counted(3, "step")`` is ``3 steps``."""

from __future__ import annotations

__all__ = ["counted"]


def counted(n: int, noun: str, plural: str = "") -> str:
    """``n`` and the noun, singular for one (``plural`` where adding an s is wrong)."""
    return f"{n} {noun if n == 1 else plural or noun + 's'}"
