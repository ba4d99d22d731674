"""The world model's beliefs in the 3-D view: a ghost box at each object's believed pose.

The physics (``world/<body>``) shows where things are; :class:`BeliefLayer` shows where the
world model *believes* they are: for each object it follows, a wireframe box in a colour of its own
``belief/<label>`` at the element's world pose (its ``pose`` frames chained up to the world,
:class:`wm_store.reasoners.SpatialReasoner`) with the element's ``size``. A prior that is a
centimetre off, a part believed in the gripper while it lies on the floor, a robot believed at
its last goal: the ghost and the body part ways. Hide them all by the entity path ``belief``.

:meth:`BeliefLayer.update` is called after each world-model change (on the event loop, with
the recording's time set): it logs only the ghosts that moved, and clears the ghost of an
element that is gone or has no pose any more.
"""

from __future__ import annotations

from collections.abc import Iterable

import rerun as rr

from wm_store import WmError
from wm_store.reasoners import SpatialReasoner
from wm_store.scene import SceneState

from ._blueprint import BELIEF

__all__ = ["GHOST_COLOR", "BeliefLayer"]

GHOST_COLOR = (80, 235, 255, 200)
"""Bright cyan, a little transparent: no scenario paints a body in it."""
_LINE = 0.003  # m: the ghost's edges

Ghost = tuple[tuple[float, ...], ...]  # centre, rotation (x, y, z, w), size: what is drawn


class BeliefLayer:
    """Ghosts of the elements labelled ``labels`` (the objects of the scene) in ``rec``."""

    def __init__(self, rec: rr.RecordingStream, labels: Iterable[str]) -> None:
        self.rec = rec
        self.labels = sorted(set(labels))
        self._shown: dict[str, Ghost] = {}

    @property
    def shown(self) -> list[str]:
        """The labels with a ghost now."""
        return sorted(self._shown)

    @staticmethod
    def entity(label: str) -> str:
        return f"{BELIEF}/{label}"

    @staticmethod
    def believed(state: SceneState, label: str) -> Ghost | None:
        """Where the world model has ``label`` (centre, rotation, size), or None: no such
        element (or several), or no pose or size."""
        ids = state.ids_with_label(label)
        if len(ids) != 1:
            return None
        spatial = SpatialReasoner(state)
        (element,) = ids
        try:
            transform = spatial.world_transform(element)
            size = spatial.extent(element)
        except WmError:
            return None
        return (transform.translation, transform.rotation, size)

    def update(self, state: SceneState) -> list[str]:
        """Log the ghosts that changed since the last call; returns their labels."""
        changed: list[str] = []
        for label in self.labels:
            ghost = self.believed(state, label)
            if ghost == self._shown.get(label):
                continue
            changed.append(label)
            if ghost is None:
                del self._shown[label]
                self.rec.log(self.entity(label), rr.Clear(recursive=False))
                continue
            self._shown[label] = ghost
            center, rotation, size = ghost
            self.rec.log(
                self.entity(label),
                rr.Boxes3D(
                    half_sizes=[[s / 2 for s in size]],
                    centers=[center],
                    quaternions=[rr.Quaternion(xyzw=rotation)],
                    colors=[GHOST_COLOR],
                    radii=[_LINE],
                    fill_mode="majorwireframe",
                ),
            )
        return changed
