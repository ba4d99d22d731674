"""The event log's errors: :class:`EventLogError` (under the application's root)."""

from __future__ import annotations

from ..errors import SkimeshError

__all__ = ["EventLogError"]


class EventLogError(SkimeshError):
    """The event log cannot be opened, reached or queried (the message says which)."""
