"""Simulated object sensors (simulation thread): a camera and a smart platform.

Both answer ``Detect`` at once with ground truth made imperfect:

- **Camera**: objects (parts, containers, appliances) whose centre is in front of the camera,
  within ``range`` and inside the field of view (vertical ``fov``, horizontal for a 4:3
  image), and, with ``occlusion``, parts that are not hidden (a ray from the camera to the
  part's centre first hits that part; boxes and appliances are large and always seen).
  Position noise: Gaussian, ``noise_std`` per axis at 1 m, growing with depth; orientation:
  true. Poses are object *centres* (the world model's convention), not body origins.
  Confidence falls with depth and towards the image border.
- **Smart platform** (FRIEND II's tactile tray): free objects standing on the platform top
  (their bottom within 1 cm of it, their centre over it), reported at the centre of their
  footprint on the surface, with ``noise_std`` Gaussian noise in x and y.

Each sensor has its own seeded ``numpy.random.Generator`` (reproducible, no global RNG).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import mujoco
import numpy as np

from device_drivers import CommandError, Detection, DeviceKey
from device_drivers.protocol import Detect
from mujoco_sim._snapshot import ObjectInfo
from mujoco_sim.control._job import NOT_INSTANT, Controller, Job
from mujoco_sim.motion._math import pose_of
from scenario import FurnitureEntry, SensorEntry, WorldPlacement

__all__ = ["CameraController", "PlatformController"]

_RAY_GROUPS = np.array([1, 0, 1, 0, 0, 0], dtype=np.uint8)  # collision geoms, not visual ones


class _Sensor(Controller):
    def __init__(
        self,
        key: DeviceKey,
        entry: SensorEntry,
        model: Any,
        data: Any,
        objects: Mapping[str, ObjectInfo],
        seed: int,
    ) -> None:
        super().__init__(key, entry.label)
        self.m, self.d, self.entry = model, data, entry
        self.objects = dict(objects)
        self.rng = np.random.default_rng(seed)

    def instant(self, job: Job, t: float) -> Any:
        if isinstance(job.command, Detect):
            return self.detect()
        return NOT_INSTANT  # begin() refuses every other command

    def begin(self, job: Job, t: float) -> None:
        raise CommandError(f"{self.label} (a sensor) cannot {type(job.command).__name__}")

    def detect(self) -> list[Detection]:
        raise NotImplementedError


class CameraController(_Sensor):
    def __init__(
        self,
        key: DeviceKey,
        entry: SensorEntry,
        model: Any,
        data: Any,
        objects: Mapping[str, ObjectInfo],
        seed: int,
    ) -> None:
        super().__init__(key, entry, model, data, objects, seed)
        site = f"{entry.mount}/{entry.site}" if entry.mount else entry.label
        self.site = model.site(site).id
        self.own_body = int(model.site_bodyid[self.site]) if entry.mount else -1
        self.tan_v = math.tan(math.radians(entry.fov) / 2)
        self.tan_h = 4.0 / 3.0 * self.tan_v

    def detect(self) -> list[Detection]:
        d, e = self.d, self.entry
        origin = d.site_xpos[self.site].copy()
        rot = d.site_xmat[self.site].reshape(3, 3)
        found = []
        geom = np.zeros(1, dtype=np.int32)
        for obj in self.objects.values():
            body_rot = d.xmat[obj.body].reshape(3, 3)
            centre = d.xpos[obj.body] + body_rot[:, 2] * (obj.half[2] - obj.bottom)
            x, y, z = rot.T @ (centre - origin)
            depth = -z  # a camera looks along its -z
            if not 0.05 < depth <= e.range:
                continue
            off_h, off_v = abs(x) / (depth * self.tan_h), abs(y) / (depth * self.tan_v)
            if max(off_h, off_v) > 1.0:
                continue
            if e.occlusion and obj.kind == "part":  # boxes are large: a part in one hides it not
                ray = centre - origin
                hit = mujoco.mj_ray(self.m, d, origin, ray, _RAY_GROUPS, 1, self.own_body, geom)
                if geom[0] >= 0 and int(self.m.geom_bodyid[geom[0]]) != obj.body and hit < 0.98:
                    continue  # something else is in the way (hit is a fraction of the ray)
            sigma = e.noise_std * max(depth, 0.2)
            noisy = centre + self.rng.normal(0.0, sigma, 3)
            confidence = 1.0 - 0.4 * depth / e.range - 0.3 * max(off_h, off_v)
            found.append(
                Detection(
                    name=obj.label,
                    type=obj.type,
                    pose=pose_of(noisy, d.xquat[obj.body]),
                    confidence=round(float(min(max(confidence, 0.05), 1.0)), 3),
                    source=self.label,
                )
            )
        return sorted(found, key=lambda det: det.name)


class PlatformController(_Sensor):
    def __init__(
        self,
        key: DeviceKey,
        entry: SensorEntry,
        model: Any,
        data: Any,
        objects: Mapping[str, ObjectInfo],
        seed: int,
        surface: FurnitureEntry,
        placed: WorldPlacement,
    ) -> None:
        movable = {k: v for k, v in objects.items() if v.free_dof >= 0}
        super().__init__(key, entry, model, data, movable, seed)
        self.top, self.placed = surface.top, placed
        self.half = (surface.size[0] / 2, surface.size[1] / 2)

    def detect(self) -> list[Detection]:
        d, p = self.d, self.placed
        c, s = math.cos(p.yaw), math.sin(p.yaw)
        found = []
        for obj in self.objects.values():
            bx, by, bz = d.xpos[obj.body]
            if abs(bz - obj.bottom - self.top) > 0.01:
                continue
            lx, ly = c * (bx - p.x) + s * (by - p.y), -s * (bx - p.x) + c * (by - p.y)
            if abs(lx) > self.half[0] or abs(ly) > self.half[1]:
                continue
            nx, ny = self.rng.normal(0.0, self.entry.noise_std, 2)
            found.append(
                Detection(
                    name=obj.label,
                    type=obj.type,
                    pose=pose_of((bx + nx, by + ny, self.top), d.xquat[obj.body]),
                    confidence=0.95,
                    source=self.label,
                )
            )
        return sorted(found, key=lambda det: det.name)
