"""The errors of site security: :class:`SecureError` (under the application's root)."""

from __future__ import annotations

from ..errors import SkimeshError

__all__ = ["SecureError"]


class SecureError(SkimeshError):
    """Credentials or the policy of a site cannot be made or read (the message says which)."""
