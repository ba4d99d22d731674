"""The errors of the skimesh application: :class:`SkimeshError` is the root of every one.

The command line prints an error a user can act on as one line with exit code 2
(:data:`skimesh.cli.USER_ERRORS`, which holds this root beside the other packages' roots).
"""

from __future__ import annotations

__all__ = ["DemoError", "SkimeshError"]


class SkimeshError(Exception):
    """Root of the skimesh application's errors."""


class DemoError(SkimeshError):
    """The demo cannot start (a busy data directory, a scenario without agents, ...)."""
