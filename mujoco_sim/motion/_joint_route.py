"""Collision-free joint moves: which configuration a joint move goes to, and through what.

:meth:`JointRouter.route` is what the arm controller asks before every joint move (a
``MoveJoints``, or a ``MoveTcp`` without ``straight``), in the simulation thread:

1. the straight joint path to the target, checked by
   :class:`~mujoco_sim.motion.JointPathCheck`: free, it is the move (the usual case,
   and the only cost);
2. for a tool target, other IK solutions of the same tool pose: the target with its revolute
   joints turned by whole turns towards the start (the same pose, another way round: joints
   such as the UR5e's span two turns), and damped-least-squares solutions from other seeds
   (the start posture, the rest posture, a few fixed random postures) with their nearest
   turns; the collision-free one closest to the start (Euclidean, over the arm joints) wins;
3. a detour through the arm's rest posture (its home): start -> rest -> the target or the
   alternative closest to the rest posture, both legs free;
4. else :class:`CollisionError`, before anything moved, naming the first collision of the
   straight path.

A ``MoveJoints`` target is kept as given (no alternatives: its joint values are the
command), so only the detour is tried for it. Steps 2-4 solve IK per seed and check
each candidate path: spent only when the straight path collides.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import mujoco
import numpy as np

from device_drivers import CollisionError, UnreachableError
from mujoco_sim.ik._core import IKOptions, TcpTarget, random_configurations
from mujoco_sim.ik._dls import DlsIK
from mujoco_sim.motion._joint_path import JointPathCheck, PathHit
from mujoco_sim.motion._math import PEAK_SPEED, Array, minjerk
from scenario import RobotLayout

__all__ = ["JointRouter", "TimedRoute"]

_SEEDS = 8  # fixed random seed postures for alternative IK solutions
_SAME = 1e-3  # rad: two solutions closer than this (every joint) are one
_TURN = 2.0 * math.pi


class JointRouter:
    """Routes joint moves of robot ``layout`` (see the module doc). ``model`` holds the robot
    (a private copy: the tracker's); ``rest`` is the arm's rest posture (arm joints). Vectors
    are chain vectors: base joints, then arm joints. Simulation thread only."""

    def __init__(
        self,
        model: Any,
        layout: RobotLayout,
        rest: Sequence[float],
        *,
        label: str = "arm",
        seed: int = 0,
    ) -> None:
        self.check = JointPathCheck(model, layout, seed=seed)
        self.ik = DlsIK(
            model,
            tcp_site=layout.tcp_site,
            arm_joints=layout.arm_joints,
            base_joints=layout.base_joints,
            options=IKOptions(restarts=0, max_iterations=30),
        )
        """Damped least squares on ``model``, from one start (no restarts), 30 iterations."""
        self.label = label
        self._chain = layout.base_joints + layout.arm_joints
        self._n = len(layout.base_joints)
        self._rest = np.asarray(rest, dtype=np.float64)
        joints = [model.joint(name).id for name in self._chain]
        limited = model.jnt_limited[joints].astype(bool)
        self._lower = np.where(limited, model.jnt_range[joints, 0], -np.inf)
        self._upper = np.where(limited, model.jnt_range[joints, 1], np.inf)
        self._turns = model.jnt_type[joints] == mujoco.mjtJoint.mjJNT_HINGE
        self._turns[: self._n] = False  # the base goes where it was told
        lower, upper = self._lower[self._n :], self._upper[self._n :]
        self._seeds = random_configurations(lower, upper, _SEEDS, seed)

    def route(self, q0: Array, q1: Array, target: TcpTarget | None = None) -> list[Array]:
        """The waypoints after ``q0`` of a collision-free joint move to ``q1`` (whose tool pose
        is ``target``, if other IK solutions may replace it); the last is where the move ends.

        Raises:
            CollisionError: no tried path is free (nothing has moved).
        """
        hit = self.check.first_hit(q0, q1)
        if hit is None:
            return [q1]
        others = [] if target is None else self._alternatives(q0, q1, target)
        for q in others:
            if self.check.first_hit(q0, q) is None:
                return [q]
        rest = q0.copy()
        rest[self._n :] = self._rest
        if self.check.first_hit(q0, rest) is None:
            for q in sorted([q1, *others], key=lambda q: _distance(q, rest, self._n)):
                if self.check.first_hit(rest, q) is None:
                    return [rest, q]
        raise self._blocked(hit, len(others))

    def _alternatives(self, q0: Array, q1: Array, target: TcpTarget) -> list[Array]:
        """Other IK solutions of ``target`` (base as in ``q1``), closest to ``q0`` first."""
        found = [self._nearest_turn(q1, q0)]
        n = self._n
        for seed in (q0[n:], self._rest, *self._seeds):
            start = q1.copy()
            start[n:] = seed
            try:
                solved = self.ik.solve(dict(zip(self._chain, start.tolist(), strict=True)), target)
            except UnreachableError:
                continue
            q = q1.copy()
            q[n:] = [solved.joints[name] for name in self._chain[n:]]
            found += [q, self._nearest_turn(q, q0)]
        unique: list[Array] = []
        for q in sorted(found, key=lambda q: _distance(q, q0, n)):
            if all(np.abs(q - u).max() > _SAME for u in [q1, *unique]):
                unique.append(q)
        return unique

    def _nearest_turn(self, q: Array, near: Array) -> Array:
        """``q`` with each arm hinge turned by whole turns as close to ``near`` as its limits
        allow (the same tool pose)."""
        turns = np.round((near - q) / _TURN)  # the distance is convex in the turns: clip
        low = np.ceil((self._lower - q) / _TURN - 1e-9)
        turns = np.clip(turns, low, np.floor((self._upper - q) / _TURN + 1e-9))
        return np.where(self._turns, q + _TURN * turns, q)

    def _blocked(self, hit: PathHit, tried: int) -> CollisionError:
        others = f"{tried} other IK solutions and " if tried else ""
        return CollisionError(
            f"{self.label}: no collision-free joint move to the target: on the straight path "
            f"{hit}; {others}a detour through the rest posture collide too (move the base so "
            "that the target is in front of the arm, or approach it from elsewhere)"
        )


class TimedRoute:
    """A route in time: a minimum-jerk segment from each waypoint to the next, from ``q0``
    through ``route``, each lasting ``PEAK_SPEED x span / speed`` (``span``: the largest joint
    change; at least 0.4 s); a given ``duration`` is shared out over them by their spans."""

    def __init__(
        self, q0: Array, route: Sequence[Array], duration: float | None, speed: float
    ) -> None:
        starts = [q0, *route[:-1]]
        spans = [float(np.abs(b - a).max()) for a, b in zip(starts, route, strict=True)]
        if duration:
            total = sum(spans)
            periods = [duration * (s / total if total else 1 / len(spans)) for s in spans]
        else:
            periods = [max(0.4, PEAK_SPEED * s / speed) for s in spans]
        self._segments = list(zip(starts, route, periods, strict=True))
        self.period = sum(periods)
        """The duration of the whole route, s."""

    def at(self, elapsed: float) -> Array:
        """The set-points ``elapsed`` seconds after the start (the end once it is over)."""
        for a, b, period in self._segments[:-1]:
            if elapsed <= period:
                return a + minjerk(elapsed / period) * (b - a)
            elapsed -= period
        a, b, period = self._segments[-1]
        return a + minjerk(elapsed / period) * (b - a)


def _distance(a: Array, b: Array, n: int) -> float:
    return float(np.linalg.norm(a[n:] - b[n:]))
