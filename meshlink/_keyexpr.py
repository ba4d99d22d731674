"""Key-expression matching, for servers that answer wildcard queries themselves (e.g. the world
model's storage-style ``wm/elements/**``)."""

from __future__ import annotations

import zenoh

from ._errors import InvalidKeyError

__all__ = ["intersects"]


def intersects(selector: str, key: str) -> bool:
    """Whether the key expression ``selector`` (wildcards allowed) matches some key that
    ``key`` also matches. Raises :class:`InvalidKeyError` for a malformed expression."""
    try:
        return bool(zenoh.KeyExpr(selector).intersects(zenoh.KeyExpr(key)))
    except zenoh.ZError as e:
        raise InvalidKeyError(f"invalid key expression {selector!r} or {key!r}: {e}") from None
