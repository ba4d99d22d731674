"""Contacts between two robots' bodies: a health figure of the world, kept for the whole run.

Robots should never touch each other (the task layer gives each robot a place of its own and
makes the next one wait). :class:`RobotContacts` maps every geom to the robot whose body it
belongs to (body names start with the robot's prefix ``<name>/``: base, arm, gripper), then
after every control tick (every ``mj_step`` call) reads MuJoCo's contact list and records each
contact whose two geoms belong to two different robots: how many ticks had one, the first
(simulated time and the two bodies) and every pair of robots that touched. What a robot holds
or carries (a part, its kit box) is no robot body. One vectorised pass over the contacts per
tick; nothing when there is no contact at all.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from msgspec import Struct

__all__ = ["RobotContact", "RobotContacts"]


class RobotContact(Struct, frozen=True):
    """A contact between two robots' bodies."""

    time: float
    """Simulated seconds."""
    robots: tuple[str, str]
    bodies: tuple[str, str]

    def __str__(self) -> str:
        return (
            f"{self.robots[0]} and {self.robots[1]} touched at t = {self.time:.2f} s "
            f"({self.bodies[0]} / {self.bodies[1]})"
        )


class RobotContacts:
    """Records contacts between robots (simulation thread only; see the module doc)."""

    def __init__(self, model: Any, prefixes: Mapping[str, str]) -> None:
        """``prefixes``: robot name -> the prefix of its element names."""
        self.robots = list(prefixes)
        owner = np.full(model.ngeom, -1, dtype=int)
        for g in range(model.ngeom):
            body = str(model.body(int(model.geom_bodyid[g])).name)
            for i, prefix in enumerate(prefixes.values()):
                if body.startswith(prefix):
                    owner[g] = i
                    break
        self._owner = owner
        self.ticks = 0
        """Control ticks that ended with at least one contact between two robots."""
        self.first: RobotContact | None = None
        self.pairs: set[tuple[str, str]] = set()

    def check(self, model: Any, data: Any) -> None:
        """Record the contacts between robots in ``data``'s current contact list."""
        n = int(data.ncon)
        if n == 0:
            return
        contacts = data.contact
        g1 = np.asarray(contacts.geom1[:n], dtype=int)
        g2 = np.asarray(contacts.geom2[:n], dtype=int)
        r1, r2 = self._owner[g1], self._owner[g2]
        hits = np.flatnonzero((r1 >= 0) & (r2 >= 0) & (r1 != r2))
        if hits.size == 0:
            return
        self.ticks += 1
        for k in hits:
            pair = tuple(sorted((self.robots[r1[k]], self.robots[r2[k]])))
            self.pairs.add((pair[0], pair[1]))
        if self.first is None:
            k = int(hits[0])
            bodies = (
                str(model.body(int(model.geom_bodyid[g1[k]])).name),
                str(model.body(int(model.geom_bodyid[g2[k]])).name),
            )
            robots = (self.robots[r1[k]], self.robots[r2[k]])
            self.first = RobotContact(time=float(data.time), robots=robots, bodies=bodies)
