"""Where the 3-D view's camera looks: framing a set of points, and the points of a scene.

:func:`scene_points` takes the corners of every visible geom of a MuJoCo world that belongs to
a body (robots' bases, stations, shelves, boxes, parts; not the world body's own geoms: the
floor and anything drawn on it), and :func:`frame` places an orbital camera that looks at
their centre from a fixed direction and just fits them, so the default view shows the robots
and the work however large the floor and wherever the scenario puts things.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["ASPECT", "Eye", "Vec", "frame", "geom_corners", "scene_points"]

_FOV_Y = 55.0  # degrees: the vertical field of view of rerun's 3-D views
ASPECT = 1.6
"""Width / height of the default layout's 3-D view in a 16:9 window (3/5 of its width, 7/10
of its height less the panels' title bars: see ``blueprint``)."""
Vec = np.ndarray[Any, Any]


@dataclass(frozen=True)
class Eye:
    """Where the 3-D view's camera is and what it looks at (world coordinates, metres)."""

    position: tuple[float, float, float]
    look_target: tuple[float, float, float]


def frame(
    points: Vec,
    *,
    azimuth: float = 225.0,
    elevation: float = 38.0,
    fill: float = 0.9,
    aspect: float = ASPECT,
    fov_y: float = _FOV_Y,
) -> Eye:
    """A camera that frames ``points`` (n x 3, world coordinates; e.g.
    :meth:`RecordingFacts.corners` or :func:`scene_points`): looking from ``azimuth`` degrees
    (0: from +x, counter-clockwise seen from above) and ``elevation`` degrees above the
    horizon, the points centred and filling ``fill`` of a view of ``aspect`` (width / height)
    with a vertical field of view of ``fov_y`` degrees."""
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    center = (points.min(axis=0) + points.max(axis=0)) / 2
    az, el = math.radians(azimuth), math.radians(elevation)
    back = np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])
    right = np.cross(-back, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, -back)
    tan_y = math.tan(math.radians(fov_y) / 2) * fill
    tan_x = tan_y * aspect

    def fit(center: Vec) -> tuple[float, float, float]:
        """The distance at which every point is in view, and how far off centre (right,
        up) the points' picture is then, per unit of depth."""
        v = points - center
        # seen from center + distance * back, a point is at depth distance - v.back; it is
        # in view if |v.up| <= depth * tan_y and |v.right| <= depth * tan_x
        along, x, y = v @ back, v @ right, v @ up
        distance = max(0.5, float(np.max(along + np.maximum(abs(y) / tan_y, abs(x) / tan_x))))
        depth = distance - along
        mid_x = float(np.max(x / depth) + np.min(x / depth)) / 2
        mid_y = float(np.max(y / depth) + np.min(y / depth)) / 2
        return distance, mid_x, mid_y

    for _ in range(3):  # centre the picture on the points, then fit them
        distance, mid_x, mid_y = fit(center)
        center = center + distance * (mid_x * right + mid_y * up)
    distance, _, _ = fit(center)
    position = center + distance * back
    return Eye(
        position=(float(position[0]), float(position[1]), float(position[2])),
        look_target=(float(center[0]), float(center[1]), float(center[2])),
    )


def scene_points(model: Any, data: Any, *, robots: Sequence[str] = ()) -> Vec:
    """The corners of every visible geom of a MuJoCo world that belongs to a body (the world
    body's own geoms, the floor among them, are left out): each geom's bounding box in its own
    frame (``geom_aabb``), placed where the geom is; none below the floor. Of each robot in
    ``robots`` (bodies ``<robot>/...``) only the base (``<robot>/base``) counts: an arm in its
    start posture, raised, would stretch the view far above where it works. For
    :func:`frame`; call it after ``mj_forward``. Reads the model's and data's arrays only, so
    it needs no mujoco import."""
    arms = tuple(f"{robot}/" for robot in robots)
    bases = {f"{robot}/base" for robot in robots}

    def counts(body: int) -> bool:
        if body == 0:
            return False
        name = str(model.body(body).name)
        return name in bases or not name.startswith(arms)

    seen = [
        g
        for g in range(model.ngeom)
        if model.geom_rgba[g, 3] > 0 and counts(int(model.geom_bodyid[g]))
    ]
    if not seen:
        return np.zeros((1, 3))
    points = geom_corners(model, data, seen)
    points[:, 2] = np.maximum(points[:, 2], 0.0)
    return points


def geom_corners(model: Any, data: Any, geoms: Sequence[int]) -> Vec:
    """The 8 corners of each geom's bounding box (``geom_aabb``, in the geom's frame) where
    the geom is now (n x 3, world coordinates)."""
    aabb = np.asarray(model.geom_aabb, dtype=float)[list(geoms)]  # centre (3), half sizes (3)
    signs = np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).T.reshape(-1, 3)
    local = aabb[:, None, :3] + aabb[:, None, 3:] * signs[None, :, :]  # geom frame
    rotation = np.asarray(data.geom_xmat, dtype=float)[list(geoms)].reshape(-1, 3, 3)
    center = np.asarray(data.geom_xpos, dtype=float)[list(geoms)]
    points = np.einsum("gij,gcj->gci", rotation, local) + center[:, None, :]
    return np.asarray(points.reshape(-1, 3), dtype=float)
