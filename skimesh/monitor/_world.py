"""The 3-D world of a monitored site: the scenario's model posed from what the mesh says.

:class:`WorldFeed` keeps a :class:`~mujoco_sim.recording.Mirror` up to date and lets its
:class:`~mujoco_sim.recording.Recorder` sample it, as a running world would:

- every device's published state (``devices/*/*/state``, :data:`device_drivers.protocol.
  StateMessage`): robots' bases and arms, grippers, appliance doors;
- the objects' poses: from the simulator's ground truth (``sim/truth``, a ``Poses`` request
  every ``truth_period`` s, whose replies also set the clock, :class:`MeshClock`) while a
  simulator answers; else from the world model's beliefs (each object's pose in the replica);
- a sample every ``1 / rate`` wall seconds, on a worker thread (the mirror's kinematics and the
  recorder's batching stay off the event loop).

**Camera images**: no device publishes images on the mesh today (a sensor answers ``Detect``
with detections). ``skimesh monitor --images`` renders the scenario's cameras from the
mirrored world (the recorder's :class:`~mujoco_sim.recording.CameraThread`, as ``skimesh sim
--images`` does from the physics); a sensor that publishes its images would hand each one to
:meth:`WorldFeed.camera_image`, which logs it where the layout shows cameras.
"""

from __future__ import annotations

import logging
from typing import Any

import anyio
import rerun as rr
from anyio.abc import TaskStatus

from device_drivers import DeviceError, WorldPose
from device_drivers.protocol import StateMessage
from device_drivers.truth import Poses, PosesReply, TruthClient
from meshlink import InvalidKeyError, Mesh
from meshlink.rpc import Decoder, WireError
from mujoco_sim.recording import Mirror, Recorder
from wm_store import WmClient

from ..recording import BeliefLayer
from ..recording._blueprint import camera_entity
from ._clock import MeshClock

__all__ = ["WorldFeed"]

_log = logging.getLogger(__name__)
_states: Decoder[StateMessage] = Decoder(StateMessage, what="device state")


class WorldFeed:
    """Follows the world into ``recorder`` through ``mirror`` (see the module doc); ``wm``:
    the beliefs used while no simulator answers."""

    def __init__(
        self,
        mirror: Mirror,
        recorder: Recorder,
        clock: MeshClock,
        *,
        wm: WmClient | None = None,
        rate: float = 25.0,
        truth_period: float = 0.2,
    ) -> None:
        self.mirror, self.recorder, self.clock, self.wm = mirror, recorder, clock, wm
        self.period = 1.0 / rate
        self.truth_period = truth_period
        self.states = 0
        """Device states taken."""
        self.source = "none"
        """Where the objects' poses come from now: ``truth``, ``beliefs`` or ``none``."""

    async def run(
        self, mesh: Mesh, *, task_status: TaskStatus[None] = anyio.TASK_STATUS_IGNORED
    ) -> None:
        """Follow until cancelled; ``started`` once subscribed to the devices' states."""
        async with anyio.create_task_group() as tg:
            await tg.start(self._states, mesh)
            tg.start_soon(self._objects, mesh)
            tg.start_soon(self._samples)
            task_status.started()

    async def _states(self, mesh: Mesh, *, task_status: TaskStatus[None]) -> None:
        async with mesh.subscribe(mesh.keys.devices_state()) as samples:
            task_status.started()
            async for sample in samples:
                if sample.kind != "put":
                    continue
                try:
                    owner, device = mesh.keys.device_of_state_key(sample.key)
                    self.mirror.apply(owner, device, _states.decode(sample.payload))
                    self.states += 1
                except (WireError, InvalidKeyError) as e:
                    _log.warning("skipped a device state on %s: %s", sample.key, e)

    async def _objects(self, mesh: Mesh) -> None:
        truth = TruthClient(mesh, timeout=max(self.truth_period * 5, 1.0))
        labels = self.mirror.objects
        while True:
            if not await self._from_truth(truth, labels):
                self._from_beliefs(labels)
            await anyio.sleep(self.truth_period)

    async def _from_truth(self, truth: TruthClient, labels: list[str]) -> bool:
        try:
            reply = await truth.answer(Poses(labels=labels))
        except DeviceError as e:
            if self.source != "beliefs":
                _log.info("objects from the world model's beliefs: no ground truth (%s)", e)
            return False
        if not isinstance(reply, PosesReply):
            return False
        self.clock.observe(reply.time)
        for label, pose in reply.poses.items():
            self.mirror.set_object(label, pose)
        self.source = "truth"
        return True

    def _from_beliefs(self, labels: list[str]) -> None:
        if self.wm is None:
            self.source = "none"
            return
        state = self.wm.replica.state
        for label in labels:
            ghost = BeliefLayer.believed(state, label)
            if ghost is not None:
                (x, y, z), (qx, qy, qz, qw), _size = ghost
                self.mirror.set_object(label, WorldPose(x, y, z, qx, qy, qz, qw))
        self.source = "beliefs"

    async def _samples(self) -> None:
        while True:
            await anyio.to_thread.run_sync(self.mirror.sample, self.recorder, self.clock())
            await anyio.sleep(self.period)

    def camera_image(self, camera: str, image: Any) -> None:
        """A camera's image from the mesh (an ``H x W x 3`` array), logged now as the
        recorder logs rendered ones (``cameras/<camera>``): the hook for a sensor that
        publishes images."""
        self.recorder.rec.set_time("sim_time", duration=self.clock())
        self.recorder.rec.log(camera_entity(camera), rr.Image(image).compress(jpeg_quality=80))
