"""Where the 3-D view's camera looks: framing a set of points, and the points of a scene.

:func:`scene_points` takes the corners around every visible geom of a MuJoCo world that
belongs to a body (robots, stations, shelves, boxes, parts; not the world body's own geoms:
the floor and anything drawn on it), and :func:`frame` places an orbital camera that looks at
their centre from a fixed direction and just fits them, so the default view shows the robots
and the work however large the floor and wherever the scenario puts things.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["ASPECT", "Eye", "Vec", "frame", "scene_points"]

_FOV_Y = 55.0  # degrees: the vertical field of view of rerun's 3-D views
ASPECT = 1.9
"""Width / height of the default layout's 3-D view in a 16:9 window (see ``blueprint``)."""
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


def scene_points(model: Any, data: Any) -> Vec:
    """Points around every visible geom of a MuJoCo world that belongs to a body (the world
    body's own geoms, the floor among them, are left out): the corners of each geom's
    bounding cube, none below the floor. For :func:`frame`; call it after ``mj_forward``.
    Reads the model's arrays only (``ngeom``, ``geom_rgba``, ``geom_bodyid``, ``geom_rbound``
    and ``data.geom_xpos``), so it needs no mujoco import."""
    seen = [
        g
        for g in range(model.ngeom)
        if model.geom_rgba[g, 3] > 0 and int(model.geom_bodyid[g]) != 0
    ]
    if not seen:
        return np.zeros((1, 3))
    center = np.asarray(data.geom_xpos)[seen]
    radius = np.asarray(model.geom_rbound)[seen][:, None]
    cube = np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).T.reshape(-1, 3)
    points = (center[:, None, :] + radius[:, None, :] * cube[None, :, :]).reshape(-1, 3)
    points[:, 2] = np.maximum(points[:, 2], 0.0)
    return np.asarray(points, dtype=float)
