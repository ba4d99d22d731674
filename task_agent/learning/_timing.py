"""Step durations from what was learned: :class:`StepTimer` and :func:`positions`.

A step's estimate is its (agent, skill) figure in the :class:`DurationBook`; a step that
drives (``start`` and ``goal`` with poses) is estimated over the distance between the two
poses, read from the world model when the plan is made (:func:`positions`, on the event loop:
the planner's scheduling runs in a worker thread and must not read the replica).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from typing import cast

from skill_agent import WorldView
from wm_store import WmError
from wm_store.reasoners import SpatialReasoner
from wm_store.scene import SceneState

from ._durations import ROUTE_PARAMS, DurationBook

__all__ = ["StepTimer", "positions"]

Point = tuple[float, float]


class _Elements:
    """The one thing the spatial reasoner reads of a scene: elements by id."""

    def __init__(self, view: WorldView) -> None:
        self.get = view.find_element


def positions(view: WorldView, ids: Iterable[str]) -> dict[str, Point]:
    """The world (x, y) of each element of ``ids`` that has a pose (others left out)."""
    spatial = SpatialReasoner(cast("SceneState", _Elements(view)))
    out: dict[str, Point] = {}
    for element in ids:
        try:
            x, y, _ = spatial.world_transform(element).translation
        except (WmError, ValueError, TypeError):
            continue
        out[element] = (x, y)
    return out


def route(where: Mapping[str, Point], params: Mapping[str, object]) -> float | None:
    """Metres between the ``start`` and ``goal`` poses, or None if the step does not drive."""
    start, goal = (params.get(p) for p in ROUTE_PARAMS)
    a = where.get(start) if isinstance(start, str) else None
    b = where.get(goal) if isinstance(goal, str) else None
    if a is None or b is None:
        return None
    return math.hypot(b[0] - a[0], b[1] - a[1])


class StepTimer:
    """Estimates steps from a :class:`DurationBook` and the poses the plan was made with."""

    def __init__(self, book: DurationBook, where: Mapping[str, Point]) -> None:
        self.book = book
        self.where = dict(where)

    def seconds(
        self, agent: str, skill: str, params: Mapping[str, object], default: float
    ) -> float:
        """The step's estimate (``default``: the skill description's figure)."""
        return self.book.estimate(agent, skill, route(self.where, params), default)
