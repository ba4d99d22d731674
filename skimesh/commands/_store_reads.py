"""Reads from the world-model store without a replica: a command that shows a few elements asks
the store for them (no snapshot of the whole world, no ontology to load: start-up time). And
how a command names an element: its id or a label only it has (:func:`element_ids`)."""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable

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

__all__ = ["element_ids", "elements_by_name", "registered_agents"]


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
    if known:
        ids = element_ids(names, known)  # or ElementNotFoundError
        if ids != names:
            reply = await transport.request(GetElements(ids=ids), timeout=timeout)
            if isinstance(reply, ElementsReply):
                return reply.elements
    # the store's own error (an ACL, a fault)
    raise RemoteError(getattr(reply, "code", "?"), getattr(reply, "message", str(reply)))


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


def element_ids(names: Iterable[str], known: Iterable[Element]) -> list[str]:
    """The id of each of ``names``: itself where it is an id of ``known``, else the id of the
    one element it labels.

    Raises:
        ElementNotFoundError: a name is neither, or labels several elements (naming them);
            with the closest ids and labels.
    """
    elements = list(known)
    ids = {e.id for e in elements}
    out: list[str] = []
    said: list[str] = []
    for name in names:
        labelled = sorted((e.id for e in elements if e.label == name), key=id_sort_key)
        if name in ids or len(labelled) == 1:
            out.append(name if name in ids else labelled[0])
        elif labelled:
            said.append(f"{len(labelled)} elements are labelled {name!r}: give one's id "
                        f"({', '.join(labelled)})")  # fmt: skip
        else:
            everything = sorted(ids | {e.label for e in elements if e.label})
            said.append(f"no element {name!r} in the world model{did_you_mean(name, everything)}")
    if said:
        raise ElementNotFoundError("; ".join(said))
    return out
