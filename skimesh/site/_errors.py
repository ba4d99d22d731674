"""The site's errors: :class:`SiteError` (under the application's root)."""

from __future__ import annotations

from ..errors import SkimeshError

__all__ = ["SiteError"]


class SiteError(SkimeshError):
    """A site file that cannot be run as written (the message says what to change)."""
