"""Reads from the world-model store without a replica: a command that shows a few elements asks
the store for them (no snapshot of the whole world, no ontology to load: start-up time)."""

from __future__ import annotations

from collections import Counter

from meshlink import Mesh
from wm_store import WmError, ZenohTransport
from wm_store.protocol import ElementsReply, Query, Relations, RelationsReply, Resolve

__all__ = ["registered_agents"]


async def registered_agents(mesh: Mesh, *, timeout: float) -> dict[str, dict[str, object]]:
    """The agents the world model holds, by label: element id, ``available``, the robot it
    controls, its number of skills. TransportError when the store does not answer."""
    transport = ZenohTransport(mesh)
    agents = await transport.request(Resolve(query=Query(type="Agent")), timeout=timeout)
    controls = await transport.request(Relations(predicate="controls"), timeout=timeout)
    skills = await transport.request(Relations(predicate="hasSkill"), timeout=timeout)
    if not isinstance(agents, ElementsReply):
        raise WmError(f"the world model did not list the agents: {agents}")
    if not (isinstance(controls, RelationsReply) and isinstance(skills, RelationsReply)):
        raise WmError(f"the world model did not list the agents' relations: {controls}")
    robots: dict[str, str] = {}
    for r in controls.relations:
        robots.setdefault(r.subject, r.object)
    counts = Counter(r.subject for r in skills.relations)
    return {
        a.label: {
            "element": a.id,
            "available": bool(a.properties.get("available", False)),
            "robot": robots.get(a.id, ""),
            "skills": counts[a.id],
        }
        for a in agents.elements
    }
