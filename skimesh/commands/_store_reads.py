"""Reads from the world-model store without a replica: a command that shows a few elements asks
the store for them (no snapshot of the whole world, no ontology to load: start-up time)."""

from __future__ import annotations

from collections import Counter

from meshlink import Mesh
from wm_store import ElementNotFoundError, RemoteError, WmError, ZenohTransport
from wm_store.ontology import did_you_mean
from wm_store.protocol import (
    Element,
    ElementsReply,
    GetElements,
    Query,
    Relations,
    RelationsReply,
    Resolve,
)
from wm_store.scene import id_sort_key

__all__ = ["elements_by_name", "registered_agents"]


async def elements_by_name(mesh: Mesh, names: list[str], *, timeout: float) -> list[Element]:
    """The elements ``names`` give, each an id or a label only one element has (``r1-arm``).
    One read when they are all ids; else the store's listing settles them.

    Raises:
        ElementNotFoundError: a name is neither, or labels several elements (naming them);
            with the closest ids and labels.
        RemoteError: the store refused the read (an ACL, a fault).
    """
    transport = ZenohTransport(mesh)
    reply = await transport.request(GetElements(ids=names), timeout=timeout)
    if isinstance(reply, ElementsReply):
        return reply.elements
    listing = await transport.request(Resolve(query=Query()), timeout=timeout)
    known = listing.elements if isinstance(listing, ElementsReply) else []
    ids = _by_label(names, known)
    if ids is not None and ids != names:
        reply = await transport.request(GetElements(ids=ids), timeout=timeout)
        if isinstance(reply, ElementsReply):
            return reply.elements
    if not known or ids is not None:  # the store's own error
        raise RemoteError(getattr(reply, "code", "?"), getattr(reply, "message", str(reply)))
    raise ElementNotFoundError("; ".join(_unknown(names, known)))


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


def _by_label(names: list[str], known: list[Element]) -> list[str] | None:
    """Each name as an id: itself where it is one, else the id of the one element it labels;
    None when a name is neither, or labels several elements."""
    ids = {e.id for e in known}
    out = []
    for name in names:
        labelled = [e.id for e in known if e.label == name]
        if name in ids:
            out.append(name)
        elif len(labelled) == 1:
            out.append(labelled[0])
        else:
            return None
    return out


def _unknown(names: list[str], known: list[Element]) -> list[str]:
    """Why each name that is neither an id nor a unique label is refused, with the closest
    ids and labels."""
    ids = {e.id for e in known}
    said = []
    for name in names:
        labelled = sorted((e.id for e in known if e.label == name), key=id_sort_key)
        if name in ids or len(labelled) == 1:
            continue
        if labelled:
            said.append(f"{len(labelled)} elements are labelled {name!r}: give one's id "
                        f"({', '.join(labelled)})")  # fmt: skip
            continue
        names_known = sorted(ids | {e.label for e in known if e.label})
        said.append(f"no element {name!r} in the world model{did_you_mean(name, names_known)}")
    return said
