"""Resources: the devices a call locks, and calls that may run at the same time locking the
same device (an agent runs one skill per device at a time and refuses the second start).

Locks are per agent: two agents may use a device their configurations both bind (a fixed
camera) at once, so such a device conflicts only between calls of one agent; the robot and
its parts conflict across agents too (two agents of one split robot)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import NamedTuple

from skill_agent import WorldView
from skill_agent.parameters import bindings
from skill_agent.protocol import RelationCond
from skill_agent.skills import robot_capacity
from wm_store import display_name
from wm_store.ontology import Cls, Rel
from wm_store.scene import SceneState, id_sort_key

from ..taskfile import CallSite, where
from ._attempt import Attempt, is_of

__all__ = ["Sharing", "call_locks", "resource_problems", "sharing", "spot_problems", "spots_of"]


class Sharing(NamedTuple):
    """A call's agent (``""``: not known yet) and the devices it binds that the agent shares
    with others (its configuration's bindings that are not its robot's own)."""

    agent: str
    shared: frozenset[str]


def sharing(att: Attempt, *, fixed: bool) -> Sharing:
    shared = frozenset(v for v in bindings(att.desc).values() if v not in att.agent.hardware)
    return Sharing(att.agent.name if fixed else "", shared)


_AGENT = "agent:"
"""The lock of a whole agent whose devices for a call are not known."""


def call_locks(att: Attempt, view: WorldView, *, fixed: bool) -> set[str]:
    """The devices the call locks (see :mod:`task_agent.verification`): bound at run time as
    :func:`~skill_agent.parameters.specify` binds them (the agent's first device of the class)."""
    locks: set[str] = set()
    known = att.values if fixed and att.values is not None else att.given
    for spec in att.desc.parameters:
        value = known.get(spec.name)
        if value is None and spec.kind == "hardware":  # the device the agent binds, if any
            value = bindings(att.desc).get(spec.name)
        if spec.kind != "hardware" or (value is None and (spec.optional or not fixed)):
            continue
        if value is None:
            devices = sorted(att.agent.hardware, key=id_sort_key)
            value = next(
                (d for d in devices if is_of(view, d, spec.type)), f"{_AGENT}{att.agent.name}"
            )
        if isinstance(value, str):
            locks.add(value)
    return locks


def resource_problems(
    calls: Mapping[str, CallSite],
    locks: Mapping[str, set[str]],
    state: SceneState,
    sharing: Mapping[str, Sharing] | None = None,
) -> list[tuple[str, str]]:
    """``(call path, problem)`` for each call that may run at the same time as an earlier one
    locking a device it locks too (``locks``: each call's :func:`call_locks`; ``sharing``:
    each call's :func:`sharing`, so a shared device of two agents is no conflict)."""
    out = []
    alone = Sharing("", frozenset())
    for site in calls.values():
        mine, found = locks.get(site.path, set()), []
        for other in site.parallel:
            common = mine & locks.get(other, set())
            a, b = (sharing or {}).get(site.path, alone), (sharing or {}).get(other, alone)
            if a.agent and b.agent and a.agent != b.agent:
                common -= a.shared | b.shared
            if common and calls[other].order < site.order:
                what = ", ".join(_device(d, state) for d in sorted(common, key=id_sort_key))
                found.append(f"{where(other, calls[other].call)} (both lock {what})")
        if found:
            message = (
                f"may run at the same time as {'; '.join(found)}: an agent runs one skill "
                "per device at a time and refuses the second start; order them in a "
                "sequence or use other devices"
            )
            out.append((site.path, message))
    return out


def _device(lock: str, state: SceneState) -> str:
    if lock.startswith(_AGENT):
        return f"agent {lock[len(_AGENT) :]} (its devices for these calls are not known)"
    return display_name(state.get(lock), lock)


def spots_of(att: Attempt, view: WorldView) -> set[tuple[str, str]]:
    """``(place, robot)`` for each place holding one robot (``robotCapacity`` 1 or absent)
    that the call sends a robot to: a post-condition ``at(robot, place)``."""
    values = att.values if att.values is not None else att.given
    out: set[tuple[str, str]] = set()
    for cond in att.desc.post:
        if not (isinstance(cond, RelationCond) and cond.predicate == Rel.at and cond.holds):
            continue
        robot, place = values.get(cond.subject), values.get(cond.object)
        if not (isinstance(robot, str) and isinstance(place, str)):
            continue
        if is_of(view, robot, Cls.Robot) and robot_capacity(view, place) == 1:
            out.add((place, robot))
    return out


def spot_problems(
    calls: Mapping[str, CallSite], spots: Mapping[str, set[tuple[str, str]]], state: SceneState
) -> list[tuple[str, str]]:
    """``(call path, problem)`` for each call that may run at the same time as an earlier one
    sending another robot to a place that holds one robot (``spots``: each call's
    :func:`spots_of`)."""
    out = []
    for site in calls.values():
        found = []
        for place, robot in sorted(spots.get(site.path, set())):
            for other in site.parallel:
                if calls[other].order > site.order:
                    continue
                rivals = {r for p, r in spots.get(other, set()) if p == place and r != robot}
                if rivals:
                    names = ", ".join(_device(r, state) for r in sorted(rivals))
                    found.append(
                        f"{where(other, calls[other].call)} (both send a robot to "
                        f"{_device(place, state)}, which holds one: {_device(robot, state)} "
                        f"and {names})"
                    )
        if found:
            message = (
                f"may run at the same time as {'; '.join(found)}: the second robot would wait "
                "at run time until the first has left; order them in a sequence, send one "
                "elsewhere, or give the place a larger robotCapacity"
            )
            out.append((site.path, message))
    return out
