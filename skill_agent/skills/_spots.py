"""Room for robots at run time: a robot reserves a place in the world model before its base
drives there, and gives it back when it has left.

A location holds ``robotCapacity`` robots (absent: one at a station, none at a surface such
as a shelf, no limit elsewhere). Who takes room there:
the robots in its ``reservedBy`` list and the robots ``at`` it that hold no reservation (a
robot that stood there from the start). :func:`reserve` adds the robot to ``reservedBy`` with
a compare-and-set on the location's revision (``UpdateElement.expect_rev``): two robots
reserving the last place at once cannot both win, the loser reads again. When the place is
full it waits for a world-model change (a robot leaving, a reservation released) up to a time
limit, then fails naming who holds the place. :func:`release` removes the robot from every
place it reserved (but one it keeps). The store releases a lost agent's robot's reservations
(``wm_store.server``'s presence monitor).
"""

from __future__ import annotations

import time
from collections.abc import Awaitable, Callable

import anyio

from skill_agent._errors import SkillFailure
from skill_agent._skill import WorldView
from wm_store import ConflictError, WmClient, display_name
from wm_store.ontology import Cls, Prop, Rel
from wm_store.protocol import Change, Element, UpdateElement, Value

__all__ = [
    "holders",
    "release",
    "release_ops",
    "reserve",
    "reserved_by",
    "robot_capacity",
]


def reserved_by(element: Element) -> list[str]:
    """The robots holding a place at ``element`` (its ``reservedBy`` list)."""
    value = element.properties.get(Prop.reservedBy)
    return [v for v in value if isinstance(v, str)] if isinstance(value, list) else []


def robot_capacity(view: WorldView, place: str) -> int | None:
    """How many robots may stand at ``place``: its ``robotCapacity``; absent, 1 at a station,
    0 at a surface (robots work beside a shelf or a table, from a station). None: no limit
    (any other location without one), or ``place`` is no location."""
    element = view.find_element(place)
    onto = view.ontology
    if element is None or not onto.is_a(element.type, Cls.Location):
        return None
    cap = element.properties.get(Prop.robotCapacity)
    if isinstance(cap, int | float) and not isinstance(cap, bool):
        return max(int(cap), 0)
    if onto.is_a(element.type, Cls.Station):
        return 1
    return 0 if onto.is_a(element.type, Cls.Surface) else None


def holders(view: WorldView, place: str) -> set[str]:
    """The robots taking room at ``place``: reservations and robots standing there."""
    element = view.find_element(place)
    if element is None:
        return set()
    standing = {
        rel.subject
        for rel in view.query_relation(predicate=Rel.at, obj=place)
        if (e := view.find_element(rel.subject)) is not None
        and view.ontology.is_a(e.type, Cls.Robot)
    }
    return set(reserved_by(element)) | standing


async def _changed(wm: WmClient, timeout: float) -> None:
    """Return at the next world-model change or after ``timeout`` seconds."""
    event = anyio.Event()

    def on_change(_change: Change) -> None:
        event.set()

    stop = wm.on_change(on_change)
    try:
        with anyio.move_on_after(max(timeout, 0.0)):
            await event.wait()
    finally:
        stop()


def _names(wm: WmClient, ids: set[str]) -> str:
    return ", ".join(sorted(display_name(wm.find_element(i), i) for i in ids)) or "nobody"


async def reserve(
    wm: WmClient,
    robot: str,
    place: str,
    *,
    wait: float,
    waiting: Callable[[str], Awaitable[None]] | None = None,
) -> bool:
    """Reserve room for ``robot`` at ``place`` (compare-and-set), waiting up to ``wait``
    seconds while it is full; ``waiting(message)`` is awaited once when the wait starts. True
    if a reservation was added, False if none is needed (no limit there, or it holds one
    already). SkillFailure at once when no robot may stand there, and naming the holders
    when the time runs out."""
    deadline = time.monotonic() + wait
    told = False
    while True:
        cap = robot_capacity(wm, place)
        element = wm.find_element(place)
        if cap is None or element is None:
            return False
        if cap == 0:
            raise SkillFailure(
                f"{display_name(element, place)} is no place for a robot (its robotCapacity is "
                "0, or it is a surface without one): drive to a station beside it"
            )
        reserved = reserved_by(element)
        if robot in reserved:
            return False
        others = holders(wm, place) - {robot}
        left = deadline - time.monotonic()
        if len(others) < cap:
            op = UpdateElement(
                id=place,
                properties={Prop.reservedBy: [*reserved, robot]},
                expect_rev=element.rev,
            )
            try:
                await wm.transact([op])
                return True
            except ConflictError:  # another robot wrote first: read again
                await _changed(wm, min(0.2, max(left, 0.0)))
                continue
        name = display_name(element, place)
        if left <= 0:
            raise SkillFailure(
                f"no room at {name} for {display_name(wm.find_element(robot), robot)}: it holds "
                f"{cap} robot{'s' if cap != 1 else ''} and {_names(wm, others)} "
                f"{'is' if len(others) == 1 else 'are'} there (waited {wait:g} s)"
            )
        if not told and waiting is not None:
            told = True
            await waiting(f"waiting for room at {name} (held by {_names(wm, others)})")
        await _changed(wm, left)


def release_ops(
    view: WorldView, robot: str, *, keep: str = "", only: str = ""
) -> list[UpdateElement]:
    """Ops removing ``robot`` from the ``reservedBy`` of every location (or of ``only``) but
    ``keep``, each a compare-and-set on the location's revision."""
    ops = []
    for element in view.resolve_element(type=Cls.Location):
        if element.id == keep or (only and element.id != only):
            continue
        reserved = reserved_by(element)
        if robot in reserved:
            rest: Value = [r for r in reserved if r != robot]
            ops.append(
                UpdateElement(
                    id=element.id, properties={Prop.reservedBy: rest}, expect_rev=element.rev
                )
            )
    return ops


async def release(wm: WmClient, robot: str, *, keep: str = "", only: str = "") -> list[str]:
    """Remove ``robot`` from the ``reservedBy`` of every location (or of ``only``), but
    ``keep``; returns the places released."""
    for _ in range(20):  # compare-and-set; a conflict means someone else wrote: read again
        ops = release_ops(wm, robot, keep=keep, only=only)
        if not ops:
            return []
        try:
            await wm.transact(ops)
            return [op.id for op in ops]
        except ConflictError:
            await _changed(wm, 0.2)
    raise SkillFailure(f"could not release the places {robot} reserved: they keep changing")
