"""Collision checks of straight joint-space paths, on a private kinematic copy of one robot.

:class:`JointPathCheck` samples the straight line between two configurations of a robot's
chain (base joints, then arm joints) in a MuJoCo model that holds the robot (normally the
robot alone, the model :class:`~mujoco_sim.motion.TcpTracker` compiled) with its own
``MjData``; each sample is ``mj_kinematics`` + ``mj_collision`` and a look at the contacts.

What is checked, as a robotics planner's *allowed collision matrix* would set it up:

- geoms are grouped into *links*: the geoms of bodies moved by the same arm joints form one
  rigid group (a hand and its fingers are one: the fingers are not part of the chain), and the
  bodies no arm joint moves form the *fixed* group: the robot's base, pedestal and deck, plus
  any geom of the world body (a floor) if the model has one;
- checked pairs: two different moving groups (self-collision), and a moving group against the
  fixed group. MuJoCo already skips parent-child bodies; a pair of groups in contact in at least
  :data:`_ALWAYS` of random arm configurations (sampled once, here) is taken as touching by
  design and not checked either;
- a contact counts when it is deeper than ``tolerance``; a pair of geoms already in contact at
  the start of a path is not held against that path (the move may be what frees it).

Sampling: points of the robot move at most ``resolution`` metres between samples (bounded with
each joint's lever arm, measured over the random configurations); the samples are visited
ends first, then by bisection, so a colliding path is usually found out after a few. Not
modelled: the world around the robot (furniture, things on its deck) and what the hand holds.

Cost: one collision check per sample, more for the UR5e + 2F-85 (its meshes) than for the
generated robot; a joint move of 1-2 rad takes 30-150 samples (see docs/benchmarks.md,
section Simulation).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from mujoco_sim.motion._math import Array
from scenario import RobotLayout

__all__ = ["JointPathCheck", "PathHit"]

_ALWAYS = 0.95  # share of random configurations in which a pair touches "by design"
_SAMPLES = 64  # random configurations for the always-touching pairs and the lever arms
_MAX_SAMPLES = 2000  # samples of one path at most (a path across the whole joint space)


@dataclass(frozen=True)
class PathHit:
    """Where a path collides: the two bodies, the path fraction (0..1), the depth (m)."""

    bodies: tuple[str, str]
    fraction: float
    depth: float

    def __str__(self) -> str:
        a, b = self.bodies
        return f"{a} hits {b} {self.fraction:.0%} of the way ({self.depth * 1000:.0f} mm deep)"


class JointPathCheck:
    """Collision checks of chain paths for the robot ``layout`` names in ``model`` (see the
    module doc). Vectors are ordered like ``layout.base_joints + layout.arm_joints``. One
    instance per thread (it owns scratch ``MjData``)."""

    def __init__(
        self,
        model: Any,
        layout: RobotLayout,
        *,
        resolution: float = 0.02,
        tolerance: float = 1e-3,
        seed: int = 0,
    ) -> None:
        self.resolution, self.tolerance = resolution, tolerance
        self._m, self._d = model, mujoco.MjData(model)
        chain = [model.joint(name).id for name in layout.base_joints + layout.arm_joints]
        qadr = [int(model.jnt_qposadr[j]) for j in chain]
        consecutive = qadr == list(range(qadr[0], qadr[0] + len(qadr)))
        self._qadr = slice(qadr[0], qadr[-1] + 1) if consecutive else np.array(qadr)
        arm = set(chain[len(layout.base_joints) :])
        robot = model.joint(chain[0]).bodyid
        groups: dict[frozenset[int], int] = {}
        moved = np.zeros((len(chain), model.ngeom), dtype=bool)  # chain joint i moves geom g
        keys: list[frozenset[int] | None] = []
        for g in range(model.ngeom):
            joints, inside = _ancestors(model, int(model.geom_bodyid[g]), robot)
            moved[:, g] = [j in joints for j in chain]
            solid = bool(model.geom_contype[g] or model.geom_conaffinity[g])
            key = frozenset(joints & arm) if solid and (inside or not joints) else None
            if key:
                groups.setdefault(key, len(groups))
            keys.append(key)
        fixed, ignored = len(groups), len(groups) + 1
        self._group = np.array(
            [ignored if k is None else groups.get(k, fixed) for k in keys], dtype=np.intp
        )
        self._pairs = np.zeros((ignored + 1, ignored + 1), dtype=bool)
        self._pairs[: fixed + 1, : fixed + 1] = True  # moving x moving, moving x fixed
        np.fill_diagonal(self._pairs, False)  # within a group; fixed x fixed
        moving = self._group < fixed
        self._lever = np.where(model.jnt_type[chain] == mujoco.mjtJoint.mjJNT_SLIDE, 1.0, 0.0)
        self._calibrate(chain, moved & moving, seed)

    def _calibrate(self, chain: list[int], moved: Any, seed: int) -> None:
        """Sample random arm configurations: drop the pairs of groups that always touch, and
        measure each joint's lever arm (farthest moving geom from its anchor, plus its size)."""
        m, d = self._m, self._d
        limited = m.jnt_limited[chain].astype(bool)
        lower = np.where(limited, m.jnt_range[chain, 0], -math.pi)
        upper = np.where(limited, m.jnt_range[chain, 1], math.pi)
        rng = np.random.default_rng(seed)
        touching = np.zeros(self._pairs.shape, dtype=np.int64)
        for _ in range(_SAMPLES):
            q = rng.uniform(lower, upper)
            q[~limited] = 0.0  # the base stays at its reference
            now = np.zeros(self._pairs.shape, dtype=bool)
            for g1, g2, _ in self._contacts(q):
                now[self._group[g1], self._group[g2]] = now[self._group[g2], self._group[g1]] = 1
            touching += now
            for i, j in enumerate(chain):
                if self._lever[i] == 1.0 or not moved[i].any():
                    continue
                offset = d.geom_xpos[moved[i]] - d.xanchor[j]  # from the anchor: >= the axis
                reach = np.linalg.norm(offset, axis=1) + m.geom_rbound[moved[i]]
                self._lever[i] = max(self._lever[i], float(reach.max()))
        always = touching >= _ALWAYS * _SAMPLES
        self._pairs &= ~always

    def first_hit(self, q0: Array, q1: Array) -> PathHit | None:
        """The first collision found on the straight path ``q0`` -> ``q1`` (chain vectors),
        or None if every sample is free (see the module doc)."""
        exempt = {(g1, g2) for g1, g2, _ in self._contacts(q0)}
        steps, dq = self.samples(q0, q1), q1 - q0
        for k in _bisection(steps):
            for g1, g2, depth in self._contacts(q0 + (k / steps) * dq):
                if (g1, g2) not in exempt:
                    body = self._m.geom_bodyid
                    names = (self._m.body(body[g1]).name, self._m.body(body[g2]).name)
                    return PathHit(names, k / steps, depth)
        return None

    def samples(self, q0: Array, q1: Array) -> int:
        """Intervals the path is cut into: no point moves more than ``resolution`` in one."""
        travel = float(np.abs(q1 - q0) @ self._lever)
        return min(_MAX_SAMPLES, max(1, math.ceil(travel / self.resolution)))

    def _contacts(self, q: Array) -> list[tuple[int, int, float]]:
        """The checked collisions at ``q``: geom, geom, depth (m)."""
        m, d = self._m, self._d
        d.qpos[self._qadr] = q
        mujoco.mj_kinematics(m, d)
        mujoco.mj_collision(m, d)
        if not d.ncon:
            return []
        geoms, dist = d.contact.geom, d.contact.dist
        group = self._group[geoms]
        hit = self._pairs[group[:, 0], group[:, 1]] & (dist < -self.tolerance)
        if not hit.any():
            return []
        return list(zip(*geoms[hit].T.tolist(), (-dist[hit]).tolist(), strict=True))


def _ancestors(model: Any, body: int, robot: int) -> tuple[set[int], bool]:
    """The joints of ``body`` and its ancestors, and whether ``robot`` is one of them."""
    joints: set[int] = set()
    inside = False
    while body > 0:
        start = int(model.body_jntadr[body])
        joints.update(range(start, start + int(model.body_jntnum[body])))
        inside = inside or body == robot
        body = int(model.body_parentid[body])
    return joints, inside


def _bisection(steps: int) -> list[int]:
    """1..steps: the end first, then the midpoints of ever finer halves."""
    order, spans = [steps], deque([(0, steps)])
    while spans:
        lo, hi = spans.popleft()
        if hi - lo > 1:
            mid = (lo + hi) // 2
            order.append(mid)
            spans.extend(((lo, mid), (mid, hi)))
    return order
