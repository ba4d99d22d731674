"""Discovering agents over the mesh: :func:`list_agents` (whose liveliness token is alive) and
:func:`find_skills` (every reachable agent's skills, in one query).
"""

from __future__ import annotations

import logging

from meshlink import Mesh
from meshlink.rpc import WireError, encode
from skill_agent.protocol._codec import decode_reply
from skill_agent.protocol._runs import ListSkills, SkillsReply

__all__ = ["find_skills", "list_agents", "liveliness_get"]

_log = logging.getLogger(__name__)


async def liveliness_get(mesh: Mesh, key_expr: str, *, timeout: float) -> list[str]:
    """Keys of the liveliness tokens alive now that match ``key_expr``."""
    return await mesh.alive(key_expr, timeout=timeout)


async def list_agents(mesh: Mesh, *, timeout: float = 2.0) -> list[str]:
    """Names of the agents whose liveliness token is alive now, sorted."""
    keys = await liveliness_get(mesh, mesh.keys.agents(), timeout=timeout)
    names: set[str] = set()
    for key in keys:
        try:
            names.add(mesh.keys.name_of_agent_key(key))
        except ValueError:
            _log.debug("ignored liveliness key %s", key)
    return sorted(names)


async def find_skills(mesh: Mesh, *, timeout: float = 2.0) -> dict[str, SkillsReply]:
    """Every reachable agent's skills at once (one query on ``agents/*/skills``), by agent."""
    found: dict[str, SkillsReply] = {}
    for reply in await mesh.get(mesh.keys.agents_skills(), encode(ListSkills()), timeout=timeout):
        if not reply.ok:
            continue
        try:
            decoded = decode_reply(reply.payload)
        except WireError:
            _log.warning("undecodable skills reply from %s", reply.key)
            continue
        if isinstance(decoded, SkillsReply):
            found[decoded.agent] = decoded
    return dict(sorted(found.items()))
