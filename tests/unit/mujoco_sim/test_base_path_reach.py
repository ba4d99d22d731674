"""Base paths on a large site: the footprint is checked only against the obstacles within reach
of the path, which finds every obstacle that a check against all of them finds."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from device_drivers import CollisionError
from mujoco_sim.control import plan_path
from mujoco_sim.motion import rects_overlap
from scenario import Footprint

HALF = (0.3, 0.225)
START, GOAL = (0.0, 0.0, 0.0), (2.0, 0.4, 0.6)


def _straight(obstacles: list[Footprint]) -> bool:
    """Whether the straight line from START to GOAL is taken (nothing in the way)."""
    try:
        return len(plan_path(START, GOAL, HALF, obstacles)) == 2
    except CollisionError:
        return False


def test_obstacles_near_the_path_are_found_among_many() -> None:
    """Random obstacles around the line, many of them at the edge of reach: the line is free
    among all of them exactly when it is free of each one alone."""
    rng = np.random.default_rng(7)
    for _ in range(40):
        obstacles = [
            Footprint(
                f"Box-{i}",
                float(rng.uniform(-0.8, 2.8)),
                float(rng.uniform(-1.2, 1.6)),
                float(rng.uniform(-math.pi, math.pi)),
                float(rng.uniform(0.02, 0.3)),
                float(rng.uniform(0.02, 0.3)),
            )
            for i in range(6)
        ]
        assert _straight(obstacles) == all(_straight([o]) for o in obstacles)


def test_obstacles_out_of_reach_cost_no_overlap_check(monkeypatch: pytest.MonkeyPatch) -> None:
    """A site of 400 obstacles away from the path: no footprint test at all, so a drive's start
    costs the same on a site of 40 cells as on one."""
    checks = 0

    def counted(a: Any, b: Any) -> bool:
        nonlocal checks
        checks += 1
        return rects_overlap(a, b)

    monkeypatch.setattr("mujoco_sim.control._base.rects_overlap", counted)
    far = [Footprint(f"Shelf-{i}", 5.0 + i % 20, 3.0 + i // 20, 0.0, 0.3, 0.6) for i in range(400)]
    assert plan_path(START, GOAL, HALF, far) == [START, GOAL]
    assert checks == 0
    near = Footprint("Pillar-1", 1.0, 0.2, 0.0, 0.2, 0.2)
    assert len(plan_path(START, GOAL, HALF, [*far, near])) == 3  # found, and a detour taken
    assert checks > 0
