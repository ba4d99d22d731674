"""What a person saw, as world-model observations (FRIEND II: the user as a sensor).

An operator's answer may say where elements are (:class:`~task_agent.protocol.SeenAt`); the
operator skill writes each as an observation of the element's ``pose`` whose source is the
``Operator`` element, with ``seenAt`` stamped, in the run's transaction. The pose's resolution
policy weighs it with the sensors' observations; ``locate`` falls back on a recent one when
no sensor sees the object (:mod:`skill_agent.skills`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence

from skill_agent import SkillFailure
from wm_store import WmClient
from wm_store.ontology import Prop
from wm_store.protocol import Observe, Op, Orientation, Pose, Position, UpdateElement

from ..discovery import OPERATOR_CLASS
from ..protocol import SeenAt

__all__ = ["seen_text", "sighting_ops"]


def seen_text(s: SeenAt) -> str:
    """``MealBox-1 at (x, y, z)`` for a message."""
    x, y, z = s.position
    return f"{s.element} at ({x:.3f}, {y:.3f}, {z:.3f})"


def sighting_ops(wm: WmClient, operator: str, seen: Sequence[SeenAt]) -> list[Op]:
    """Pose observations of what a person saw, by the ``Operator`` element labelled
    ``operator`` (its id is the source; confidence as given), with ``seenAt`` stamped.

    Raises:
        SkillFailure: a sighting names no element (by id or label).
    """
    found = wm.resolve_element(type=OPERATOR_CLASS, label=operator)
    source = found[0].id if found else operator
    stamp = time.time()
    ops: list[Op] = []
    for s in seen:
        element = wm.find_element(s.element) or next(
            iter(wm.resolve_element(label=s.element)), None
        )
        if element is None:
            raise SkillFailure(f"the operator saw {s.element!r}: no such element")
        if s.yaw is not None:
            turn = Orientation(0.0, 0.0, math.sin(s.yaw / 2), math.cos(s.yaw / 2))
        else:
            old = element.properties.get(Prop.pose)
            turn = old.orientation if isinstance(old, Pose) else Orientation()
        pose = Pose(Position(*s.position), turn)
        ops.append(UpdateElement(id=element.id, properties={Prop.seenAt: stamp}))
        ops.append(
            Observe(
                id=element.id,
                property=Prop.pose,
                value=pose,
                source=source,
                confidence=s.confidence,
                stamp=stamp,
            )
        )
    return ops
