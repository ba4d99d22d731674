"""Grasps: which bodies the finger pads touch, and the weld that attaches a grasped object.

Close the fingers with real contacts, attach only
when *both* pads touch the same object, detach on open. The attachment is a weld equality
``<robot>/grasp/<label>`` (one per robot and graspable object, built inactive). Before it is
activated its relative pose is set to the present hand-to-object pose, so the object does not
snap. ``mode="physics"`` never welds: the object is then held by friction alone, and "holding"
means both pads touch it.

Simulation thread only (reads and writes ``MjData``/``MjModel``).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, Literal

import numpy as np

from mujoco_sim.motion._math import quat_conj, quat_mul
from scenario import RobotLayout

__all__ = ["GraspMode", "Grasping"]

GraspMode = Literal["weld", "physics"]


class Grasping:
    """Pad contacts and welds of one robot's gripper."""

    def __init__(
        self,
        model: Any,
        data: Any,
        layout: RobotLayout,
        graspables: Mapping[str, int],
        welds: Mapping[str, int],
        mode: GraspMode,
    ) -> None:
        self.m, self.d, self.mode = model, data, mode
        self.side = np.zeros(model.ngeom, dtype=np.int8)  # geom id -> 1 left pad, 2 right pad
        for side, geoms in enumerate(layout.pad_geoms, start=1):
            self.side[[model.geom(g).id for g in geoms]] = side
        self.hand = model.body(layout.hand_body).id
        self.labels = {body: label for label, body in graspables.items()}
        self.bodies = dict(graspables)
        self.welds = dict(welds)
        self.attached = ""

    def touched(self) -> tuple[set[int], set[int]]:
        """Bodies in contact with the left and with the right pad now."""
        n = self.d.ncon
        if n == 0:
            return set(), set()
        g1, g2 = self.d.contact.geom1[:n], self.d.contact.geom2[:n]
        body, s1, s2 = self.m.geom_bodyid, self.side[g1], self.side[g2]
        sides: list[set[int]] = []
        for pad in (1, 2):
            other = np.concatenate([g2[s1 == pad], g1[s2 == pad]])
            sides.append({int(b) for b in body[other]})
        return sides[0], sides[1]

    def pads_in_contact(self) -> int:
        left, right = self.touched()
        return int(bool(left)) + int(bool(right))

    def between_pads(self) -> str:
        """The graspable object both pads touch, or ""."""
        left, right = self.touched()
        both = [self.labels[b] for b in left & right if b in self.labels]
        return sorted(both)[0] if both else ""

    def attach(self, label: str) -> None:
        """Weld ``label`` to the hand where it is now (weld mode only)."""
        if self.mode != "weld":
            return
        weld, body = self.welds[label], self.bodies[label]
        d = self.d
        rot1 = d.xmat[self.hand].reshape(3, 3)
        relpos = rot1.T @ (d.xpos[body] - d.xpos[self.hand])
        relquat = quat_mul(quat_conj(d.xquat[self.hand]), d.xquat[body])
        data = self.m.eq_data[weld]
        data[0:3] = 0.0  # anchor: the object's origin
        data[3:6] = relpos
        data[6:10] = relquat / np.linalg.norm(relquat)
        d.eq_active[weld] = 1
        self.attached = label

    def detach(self) -> None:
        if self.attached:
            self.d.eq_active[self.welds[self.attached]] = 0
            self.attached = ""

    @property
    def holding(self) -> str:
        """The object held: the welded one (if the weld is still on), or in physics mode the
        one between the pads."""
        if self.mode == "physics":
            return self.between_pads()
        if self.attached and not self.d.eq_active[self.welds[self.attached]]:
            self.attached = ""  # the weld was switched off behind our back: it fell
        return self.attached
