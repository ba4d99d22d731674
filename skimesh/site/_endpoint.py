"""A router endpoint of a site file read into its parts: :func:`parse_endpoint` (the plan's
checks and probes, and the security plan's test of which addresses a site listens on)."""

from __future__ import annotations

import re

from ._errors import SiteError

__all__ = ["ANY_ADDRESS", "parse_endpoint"]

ANY_ADDRESS = frozenset({"0.0.0.0", "[::]"})
"""The addresses that listen on every interface."""

_ENDPOINT = re.compile(r"^(?P<proto>[a-z0-9-]+)/(?P<addr>\[[^\]]+\]|[^:/]+):(?P<port>\d+)(#.*)?$")


def parse_endpoint(endpoint: str) -> tuple[str, str, int]:
    """(protocol, address, port) of ``proto/address:port`` (an IPv6 address keeps its
    brackets: ``[::1]``)."""
    m = _ENDPOINT.match(endpoint)
    if m is None:
        raise SiteError(f"endpoint {endpoint!r} is not PROTOCOL/ADDRESS:PORT (tcp/10.1.2.3:7447)")
    return m["proto"], m["addr"], int(m["port"])
