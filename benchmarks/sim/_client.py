"""The simulation benchmark's deployment layout: the workload in a client process of its own.

The measured process keeps the router, the world and its device server; the client process
(``python -m benchmarks.sim --role client``, started and always stopped by PID through
:class:`benchmarks.common.Child`) joins the mesh on loopback, finds the devices with
:func:`~device_drivers.remote.connect_devices` and runs the workload
(:mod:`benchmarks.sim._workload`) through the remote proxies, as a skill agent would.

What a workload reads besides its devices (:class:`~benchmarks.sim._workload.Truth`: a few
ground-truth poses, the simulated clock for the sensor watch, the marks of the measured
window) comes from the measured process over one benchmark queryable, ``.../bench/sim-truth``
(:func:`serve_truth`, :class:`MeshTruth`): msgspec requests, one round trip each.

Child protocol (JSON lines): it writes ``{"ready": pid}`` once its session is open, waits for
one line (``go``: the devices are served), drives, writes ``{"done": {object: placed}}``, and
exits when its stdin closes (which also cancels a workload still running).
"""

from __future__ import annotations

import argparse
import os

import anyio
import anyio.abc
import msgspec
from msgspec import Struct

from benchmarks.common import emit, stdin_lines
from benchmarks.sim._workload import Truth, drive
from device_drivers import WorldPose
from device_drivers.remote import connect_devices
from meshlink import Answer, IncomingQuery, Mesh, MeshConfig, open_mesh

__all__ = ["MeshTruth", "child_client", "serve_truth", "truth_key"]


class Pose(Struct, frozen=True, tag="pose"):
    name: str


class Inside(Struct, frozen=True, tag="in"):
    label: str
    container: str


class Sleep(Struct, frozen=True, tag="sleep"):
    seconds: float


class Mark(Struct, frozen=True, tag="mark"):
    end: bool


TruthRequest = Pose | Inside | Sleep | Mark
_requests = msgspec.msgpack.Decoder(TruthRequest)
_encoder = msgspec.msgpack.Encoder()
_poses = msgspec.msgpack.Decoder(WorldPose)
_flags = msgspec.msgpack.Decoder(bool)
_TIMEOUT = 120.0  # s: a sleep of 0.5 simulated s lasts 0.5 s of wall time in real-time mode


def truth_key(mesh: Mesh) -> str:
    return f"{mesh.keys.prefix}/bench/sim-truth"


async def serve_truth(
    mesh: Mesh,
    truth: Truth,
    *,
    task_status: anyio.abc.TaskStatus[None] = anyio.TASK_STATUS_IGNORED,
) -> None:
    """Measured process: answer :class:`MeshTruth` from ``truth`` until cancelled."""
    key = truth_key(mesh)

    async def handle(query: IncomingQuery) -> list[Answer]:
        request = _requests.decode(query.payload or b"")
        value: object = None
        if isinstance(request, Pose):
            value = await truth.pose(request.name)
        elif isinstance(request, Inside):
            value = await truth.object_in(request.label, request.container)
        elif isinstance(request, Sleep):
            await truth.sleep(request.seconds)
        else:
            await truth.mark(request.end)
        return [Answer(key, _encoder.encode(value))]

    await mesh.serve(key, handle, task_status=task_status)


class MeshTruth:
    """Client process: :class:`~benchmarks.sim._workload.Truth` over :func:`serve_truth`."""

    def __init__(self, mesh: Mesh) -> None:
        self._mesh, self._key = mesh, truth_key(mesh)

    async def _ask(self, request: TruthRequest) -> bytes:
        return await self._mesh.request(self._key, _encoder.encode(request), timeout=_TIMEOUT)

    async def pose(self, name: str) -> WorldPose:
        return _poses.decode(await self._ask(Pose(name)))

    async def object_in(self, label: str, container: str) -> bool:
        return _flags.decode(await self._ask(Inside(label, container)))

    async def sleep(self, seconds: float) -> None:
        await self._ask(Sleep(seconds))

    async def mark(self, end: bool) -> None:
        await self._ask(Mark(end))


def child_client(args: argparse.Namespace) -> int:
    """The client role: ``--connect ENDPOINT --mesh M --scenario S --picks N --sensor-period
    P`` (module doc)."""
    from skimesh.runtime import run_service

    async def main() -> int:
        config = MeshConfig(connect=(args.connect,), mesh=args.mesh)
        async with open_mesh(config) as mesh, anyio.create_task_group() as tg:
            go = anyio.Event()

            async def control() -> None:
                async for _ in stdin_lines():
                    go.set()
                tg.cancel_scope.cancel()  # stdin closed: the measured process is done

            tg.start_soon(control)
            emit({"ready": os.getpid()})
            await go.wait()
            devices = await connect_devices(mesh)
            truth = MeshTruth(mesh)
            done = await drive(truth, devices, args.scenario, args.picks, args.sensor_period)
            emit({"done": done})
            await anyio.sleep_forever()
        return 0

    return run_service(main)
