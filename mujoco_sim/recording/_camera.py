"""Camera images for the rerun recording, rendered on a thread of their own.

An OpenGL (EGL) context is current in the thread that created it, and the simulation runs in
whichever worker thread anyio picks, so rendering gets one dedicated thread: the simulation
thread :meth:`CameraThread.offer` s a copy of ``qpos`` at ``rate`` Hz of simulated time (never
blocking: when the renderer lags, frames are dropped); the camera thread poses its own
``MjData`` (``mj_kinematics`` + ``mj_camlight``: nothing that reads the model fields the
simulation changes at run time), renders each camera and logs a JPEG-compressed ``rr.Image``.

Headless rendering needs ``MUJOCO_GL=egl`` (and with Mesa ``EGL_PLATFORM=surfaceless``) set
before ``mujoco`` is imported; ``skimesh sim --images`` does that. If the renderer cannot be
created, a warning is logged and no images are recorded.
"""

from __future__ import annotations

import contextlib
import logging
import queue
import threading
from collections.abc import Sequence
from typing import Any

import mujoco
import numpy as np
import rerun as rr

__all__ = ["CameraThread"]

_log = logging.getLogger(__name__)


class CameraThread:
    def __init__(
        self,
        rec: rr.RecordingStream,
        model: Any,
        cameras: Sequence[str],
        rate: float,
        *,
        width: int = 320,
        height: int = 240,
    ) -> None:
        self._rec, self._model, self._cameras = rec, model, list(cameras)
        self._period = 1.0 / rate
        self._size = (height, width)
        self._next = 0.0
        self._queue: queue.Queue[tuple[float, np.ndarray[Any, Any]] | None] = queue.Queue(2)
        self.frames = 0
        self._thread = threading.Thread(target=self._run, name="skimesh-cameras", daemon=True)
        self._thread.start()

    def offer(self, t: float, data: Any) -> None:
        """Simulation thread: hand over the pose if a frame is due (never blocks)."""
        if t + 1e-9 < self._next:
            return
        self._next = t + self._period
        with contextlib.suppress(queue.Full):  # the renderer is behind: drop this frame
            self._queue.put_nowait((t, data.qpos.copy()))

    def _run(self) -> None:
        try:
            renderer = mujoco.Renderer(self._model, *self._size)
        except Exception as exc:  # no GL here: record without images
            _log.warning("camera images disabled: cannot create a renderer (%s)", exc)
            while self._queue.get() is not None:
                pass
            return
        data = mujoco.MjData(self._model)
        what = mujoco.MjvOption()
        what.sitegroup[:] = 0  # a camera sees the world, not the model's markers (the tcp site)
        try:
            while (item := self._queue.get()) is not None:
                t, qpos = item
                data.qpos[:] = qpos
                mujoco.mj_kinematics(self._model, data)
                mujoco.mj_camlight(self._model, data)
                self._rec.set_time("sim_time", duration=t)
                for camera in self._cameras:
                    renderer.update_scene(data, camera=camera, scene_option=what)
                    image = rr.Image(renderer.render()).compress(jpeg_quality=80)
                    self._rec.log(f"cameras/{camera.replace('/', '.')}", image)
                self.frames += 1
        finally:
            renderer.close()

    def close(self) -> None:
        """Stop after the frames already handed over; wait for the thread (at most 10 s)."""
        self._queue.put(None)
        self._thread.join(timeout=10)
