"""Rerun recording of a simulated world: geometry once, body poses and joint states batched.

Logging every body every step would cost many times the physics (see docs/benchmarks.md,
section Simulation). So: geometry is logged once as static data (one
archetype per body and geom kind, in body frames); poses of the bodies that can move are
sampled at ``rate`` Hz of simulated time into numpy buffers and sent with one
``send_columns`` per body that moved, every ``flush_every`` simulated seconds; joint positions
and the gripper opening likewise (one multi-series ``Scalars`` entity per robot). Command outcomes
are ``TextLog`` lines, buffered and sent the same way (one ``send_columns`` per entity: a single
``rr.log`` per line costs more than a whole send). All data is on the ``sim_time`` timeline.

Each send costs about the same whatever its length (here and in rerun's own threads, which
encode and write every chunk), so a world running faster than real time sends bigger batches
rather than more of them: a flush waits at least ``min_flush_wall`` wall seconds after the
previous one (in real time ``flush_every`` is the longer wait), and a body that stood still
over a whole batch is sent once, with the batch's first time.

Threads: :meth:`Recorder.start`, :meth:`sample` and :meth:`log_text` run in the simulation
thread (they read ``MjData``); rerun's SDK batches and ships on its own threads. Camera images
(optional) are rendered on a thread this recorder owns (:class:`CameraThread`),
because an OpenGL context belongs to the thread that made it. The recording is an instance
(``rr.RecordingStream``), never rerun's global one.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import pyarrow as pa  # type: ignore[import-untyped]  # rerun's own dependency
import rerun as rr

__all__ = ["Recorder", "RobotSeries"]

_log = logging.getLogger(__name__)
_TIMELINE = "sim_time"
_STILL = 1e-5  # m or quaternion units: a body that moved less is not sent again
_MAX_BUFFERED = 60.0  # simulated seconds of samples a flush waits for at most


@dataclass(frozen=True, slots=True)
class RobotSeries:
    """What :class:`Recorder` plots for one robot on ``robots/<name>/joints``: the positions
    of its base and arm joints (full model names, ``<name>/`` prefixed) and its gripper's
    pad-to-pad opening in m (``opening(data)``: e.g. a gripper drive's, which works for the
    generated gripper and for one from an MJCF file alike)."""

    name: str
    joints: tuple[str, ...]
    opening: Callable[[Any], float]


def _entity(name: str) -> str:
    return "world/" + (name.replace("/", ".") or "world")


class Recorder:
    """A rerun recording of one world. ``path``: write an ``.rrd`` file; ``connect``: stream
    to a viewer (``rerun+http://HOST:9876/proxy``); both may be given. ``images``: also record
    the scenario's cameras (``width`` x ``height`` at ``image_rate`` Hz, needs EGL)."""

    def __init__(
        self,
        *,
        path: str | Path | None = None,
        connect: str | None = None,
        rate: float = 25.0,
        flush_every: float = 2.0,
        min_flush_wall: float = 0.5,
        images: bool = False,
        image_rate: float = 2.0,
        application: str = "skimesh",
        recording_id: str | None = None,
    ) -> None:
        self.rec = rr.RecordingStream(application, recording_id=recording_id)
        sinks: list[Any] = []
        if connect:
            sinks.append(rr.GrpcSink(connect))
        if path is not None:
            sinks.append(rr.FileSink(str(path)))
        if sinks:
            self.rec.set_sinks(*sinks)
        self.period = 1.0 / rate
        self.flush_every = flush_every
        self.min_flush_wall = min_flush_wall
        self._max_buffered = max(1, round(_MAX_BUFFERED * rate))  # samples: bounds the memory
        self._flushed_at = -math.inf  # time.monotonic() of the last flush
        self.images = images
        self.image_rate = image_rate
        self._next = 0.0
        self._times: list[float] = []
        self._pos: list[np.ndarray[Any, Any]] = []
        self._quat: list[np.ndarray[Any, Any]] = []
        self._joints: list[np.ndarray[Any, Any]] = []
        self._moving: np.ndarray[Any, Any] = np.zeros(0, dtype=int)
        self._names: list[str] = []
        self._robots: list[RobotSeries] = []
        self._joint_slots = self._joint_qpos = self._opening_slots = np.zeros(0, dtype=int)
        self._camera: Any = None
        self.samples = 0
        self._texts: dict[str, list[tuple[float, str, str]]] = {}
        self._closed = False

    # ------------------------------------------------------------------ simulation thread
    def start(
        self,
        model: Any,
        data: Any,
        *,
        cameras: Sequence[str] = (),
        robots: Sequence[RobotSeries] = (),
    ) -> None:
        """Log the geometry (static) and choose the bodies to follow; before stepping.
        ``robots``: whose joints and gripper opening to plot (an unknown joint name raises
        ``KeyError`` naming it)."""
        mujoco.mj_forward(model, data)
        self.rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        for body in range(model.nbody):
            self._log_geoms(model, body)
        self._names = [str(model.body(b).name) for b in range(model.nbody)]
        self._moving = np.array(
            [b for b in range(1, model.nbody) if model.body_weldid[b] != 0], dtype=int
        )
        self._sent = np.full((len(self._moving), 7), np.inf)
        static = [b for b in range(1, model.nbody) if model.body_weldid[b] == 0]
        for b in static:
            self.rec.log(_entity(self._names[b]), self._transform(data, b), static=True)
        self._robots = list(robots)
        # one sample's joint vector: per robot its joints, then its gripper opening
        slots: list[int] = []
        qpos: list[int] = []
        openings: list[int] = []
        for robot in self._robots:
            at = len(slots) + len(openings)
            slots += range(at, at + len(robot.joints))
            qpos += [int(model.jnt_qposadr[model.joint(j).id]) for j in robot.joints]
            openings.append(at + len(robot.joints))
            names = [j.removeprefix(robot.name + "/") for j in robot.joints]
            self.rec.log(
                f"robots/{robot.name}/joints",
                rr.SeriesLines(names=[*names, "gripper_opening"]),
                static=True,
            )
        self._joint_slots, self._joint_qpos = np.array(slots, int), np.array(qpos, int)
        self._opening_slots = np.array(openings, int)
        if self.images and cameras:
            from mujoco_sim.recording._camera import CameraThread

            self._camera = CameraThread(self.rec, model, cameras, self.image_rate)
        self.sample(model, data)

    @property
    def next_sample(self) -> float:
        """Simulation time of the next sample: the plant calls :meth:`sample` from then on."""
        return self._next

    def sample(self, model: Any, data: Any) -> None:
        """Buffer the state if a sample is due; flush full buffers (the plant calls it once
        :attr:`next_sample` is reached; calls before are ignored)."""
        t = float(data.time)
        if t + 1e-9 < self._next:
            return
        self._next = t + self.period
        self._times.append(t)
        self._pos.append(data.xpos[self._moving])  # fancy indexing copies
        self._quat.append(data.xquat[self._moving])
        joints = np.empty(len(self._joint_qpos) + len(self._opening_slots))
        joints[self._joint_slots] = data.qpos[self._joint_qpos]
        joints[self._opening_slots] = [robot.opening(data) for robot in self._robots]
        self._joints.append(joints)
        self.samples += 1
        if self._camera is not None:
            self._camera.offer(t, data)
        if t - self._times[0] >= self.flush_every and (
            time.monotonic() - self._flushed_at >= self.min_flush_wall
            or len(self._times) >= self._max_buffered
        ):
            self.flush()

    def log_text(self, t: float, entity: str, text: str, level: str = "INFO") -> None:
        """A line on ``events/<entity>`` at simulation time ``t`` (sent with the next flush)."""
        self._texts.setdefault(entity, []).append((t, text, level))

    def flush(self) -> None:
        """Send the buffered samples (one ``send_columns`` per followed body and robot) and
        text lines (one per entity)."""
        for entity, lines in self._texts.items():
            when, texts, levels = zip(*lines, strict=True)
            self.rec.send_columns(
                f"events/{entity}",
                indexes=[rr.TimeColumn(_TIMELINE, duration=np.array(when))],
                columns=rr.TextLog.columns(text=texts, level=levels),
            )
        self._texts = {}
        self._flushed_at = time.monotonic()
        if not self._times:
            return
        times = rr.TimeColumn(_TIMELINE, duration=np.array(self._times))
        pos, quat = np.stack(self._pos), np.stack(self._quat)[:, :, _XYZW]
        # A body that has not moved since it was last sent (a part asleep in its box, an idle
        # robot) is skipped: rerun shows its last pose anyway, and each send_columns call has a
        # fixed cost, which dominated the recorder's cost. One that stood still over this batch
        # but not where it was last sent is sent once.
        span = np.concatenate([np.ptp(pos, axis=0), np.ptp(quat, axis=0)], axis=1).max(axis=1)
        first = np.concatenate([pos[0], quat[0]], axis=1)
        still = span <= _STILL
        moved = ~still | (np.abs(first - self._sent).max(axis=1) > _STILL)
        self._sent = np.concatenate([pos[-1], quat[-1]], axis=1)
        columns, once = _TransformColumns(len(self._times)), _TransformColumns(1)
        first_time = rr.TimeColumn(_TIMELINE, duration=np.array(self._times[:1]))
        for i in np.flatnonzero(moved):
            body = self._moving[i]
            self.rec.send_columns(
                _entity(self._names[body]),
                indexes=[first_time] if still[i] else [times],
                columns=once(pos[:1, i], quat[:1, i])
                if still[i]
                else columns(pos[:, i], quat[:, i]),
            )
        joints, start = np.stack(self._joints), 0
        for robot in self._robots:
            width = len(robot.joints) + 1
            block = joints[:, start : start + width]
            start += width
            self.rec.send_columns(
                f"robots/{robot.name}/joints",
                indexes=[times],
                columns=rr.Scalars.columns(scalars=block.ravel()).partition([width] * len(block)),
            )
        self._times, self._pos, self._quat, self._joints = [], [], [], []

    def close(self) -> None:
        """Flush everything, stop the image thread and close the sinks, which finishes the
        ``.rrd`` file (idempotent; blocking: call it from a worker thread in async code)."""
        if self._closed:
            return
        self._closed = True
        self.flush()
        if self._camera is not None:
            self._camera.close()
            self._camera = None
        self.rec.flush()
        self.rec.disconnect()

    # ------------------------------------------------------------------ helpers
    @staticmethod
    def _transform(data: Any, body: int) -> rr.Transform3D:
        w, x, y, z = data.xquat[body]
        return rr.Transform3D(
            translation=data.xpos[body], quaternion=rr.Quaternion(xyzw=[x, y, z, w])
        )

    def _log_geoms(self, model: Any, body: int) -> None:
        groups: dict[int, list[int]] = {}
        for g in range(
            model.body_geomadr[body], model.body_geomadr[body] + model.body_geomnum[body]
        ):
            if model.geom_rgba[g, 3] > 0:
                groups.setdefault(int(model.geom_type[g]), []).append(g)
        base = _entity(str(model.body(body).name))
        for kind, geoms in groups.items():
            size, pos = model.geom_size[geoms], model.geom_pos[geoms]
            quat = model.geom_quat[geoms][:, [1, 2, 3, 0]]
            colors = (np.clip(model.geom_rgba[geoms], 0, 1) * 255).astype(np.uint8)
            shape: Any
            if kind == mujoco.mjtGeom.mjGEOM_BOX:
                shape = rr.Boxes3D(
                    half_sizes=size, centers=pos, quaternions=quat, colors=colors, fill_mode="solid"
                )
            elif kind == mujoco.mjtGeom.mjGEOM_PLANE:
                half = np.column_stack([size[:, 0], size[:, 1], np.full(len(geoms), 1e-3)])
                shape = rr.Boxes3D(half_sizes=half, centers=pos, colors=colors, fill_mode="solid")
            elif kind == mujoco.mjtGeom.mjGEOM_CYLINDER:
                shape = rr.Cylinders3D(
                    lengths=2 * size[:, 1],
                    radii=size[:, 0],
                    centers=pos,
                    quaternions=quat,
                    colors=colors,
                    fill_mode="solid",
                )
            elif kind == mujoco.mjtGeom.mjGEOM_CAPSULE:
                starts = np.array(
                    [
                        p - _rotate(q, [0.0, 0.0, s[1]])
                        for p, q, s in zip(pos, model.geom_quat[geoms], size, strict=True)
                    ]
                )
                shape = rr.Capsules3D(
                    lengths=2 * size[:, 1],
                    radii=size[:, 0],
                    translations=starts,
                    quaternions=quat,
                    colors=colors,
                    fill_mode="solid",  # the default draws capsules as wireframes
                )
            elif kind == mujoco.mjtGeom.mjGEOM_SPHERE:
                radii = np.repeat(size[:, :1], 3, axis=1)
                shape = rr.Ellipsoids3D(
                    half_sizes=radii, centers=pos, colors=colors, fill_mode="solid"
                )
            else:
                continue  # meshes etc.: the generated models have none
            self.rec.log(
                f"{base}/{mujoco.mjtGeom(kind).name.removeprefix('mjGEOM_').lower()}",
                shape,
                static=True,
            )


_XYZW = np.array([1, 2, 3, 0])  # MuJoCo's w, x, y, z -> rerun's x, y, z, w


class _Arrow:
    """A ready-made arrow array where rerun expects a component batch."""

    def __init__(self, array: pa.Array) -> None:
        self.array = array

    def as_arrow_array(self) -> pa.Array:
        return self.array


class _TransformColumns:
    """``rr.Transform3D.columns(translation=..., quaternion=...)`` for one flush's bodies,
    built straight from numpy: the same arrow arrays and descriptors (a unit test compares
    them), at a fraction of the cost of rerun's generic converters (see docs/benchmarks.md,
    section Simulation)."""

    _types: tuple[pa.DataType, pa.DataType] | None = None

    def __init__(self, rows: int) -> None:
        if _TransformColumns._types is None:
            one = rr.Transform3D.columns(translation=np.zeros((1, 3)), quaternion=[[0, 0, 0, 1]])
            arrays = {str(c.component_descriptor()): c.as_arrow_array() for c in one}
            _TransformColumns._types = (
                arrays["Transform3D:translation"].type.value_type,
                arrays["Transform3D:quaternion"].type.value_type,
            )
        self.types = _TransformColumns._types
        self.offsets = np.arange(rows + 1, dtype=np.int32)  # one pose per row

    def __call__(self, pos: np.ndarray[Any, Any], quat: np.ndarray[Any, Any]) -> list[Any]:
        translation, rotation = (
            pa.FixedSizeListArray.from_arrays(
                pa.array(values.astype(np.float32).ravel()), type=kind
            )
            for values, kind in ((pos, self.types[0]), (quat, self.types[1]))
        )
        return [
            rr.ComponentColumn(
                rr.Transform3D.descriptor_translation(), _Arrow(translation), offsets=self.offsets
            ),
            rr.ComponentColumn(
                rr.Transform3D.descriptor_quaternion(), _Arrow(rotation), offsets=self.offsets
            ),
        ]


def _rotate(quat_wxyz: Any, vec: list[float]) -> Any:
    out = np.zeros(3)
    mujoco.mju_rotVecQuat(out, np.asarray(vec, float), np.asarray(quat_wxyz, float))
    return out
