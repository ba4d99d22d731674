"""Place reservations of lost agents' robots: what the presence monitor releases.

The navigate skill writes ``reservedBy`` on a location (the robots holding a place there)
before its base moves. When an agent's liveliness token has been gone for ``release_after``
seconds, the store removes its robots from every ``reservedBy``, unless another live agent
controls the robot too (a split robot). The wait keeps a reservation through a router blip
(every token vanishes and comes back within seconds) and releases it for an agent that is
really gone; where the robot stands (its ``at``) still counts either way.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable

from wm_store.ontology import Cls, Prop, Rel
from wm_store.protocol import Op, UpdateElement
from wm_store.server._store import WmStore

__all__ = ["RELEASE_AFTER", "release_ops"]

RELEASE_AFTER = 15.0
"""Seconds an agent must stay lost before its robots' reservations are released."""


def release_ops(store: WmStore, agents: Iterable[str], alive: Callable[[str], bool]) -> list[Op]:
    """Ops removing the robots the Agent elements ``agents`` control from every location's
    ``reservedBy`` (compare-and-set on each location's revision), but robots another agent
    that is ``alive`` (by element id) controls."""
    state = store.state
    lost = set(agents)
    robots: set[str] = set()
    for agent in lost:
        for robot in state.objects(agent, Rel.controls):
            others = state.subjects(robot, Rel.controls) - lost
            if not any(alive(a) for a in others):
                robots.add(robot)
    if not robots:
        return []
    ops: list[Op] = []
    for place in sorted(state.ids_of_types(store.ontology.subclasses(Cls.Location))):
        element = state.elements[place]
        held = element.properties.get(Prop.reservedBy)
        if isinstance(held, list) and robots & set(held):
            rest = [r for r in held if r not in robots]
            ops.append(
                UpdateElement(id=place, properties={Prop.reservedBy: rest}, expect_rev=element.rev)
            )
    return ops
