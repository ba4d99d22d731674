"""The ground-truth queryable ``sim/truth``: :class:`GroundTruth` (what a simulator answers)
served by :func:`serve_truth`, asked by :class:`TruthClient`.

A simulator implements :class:`GroundTruth` (``mujoco_sim.SimTruth`` over a running world);
:func:`serve_truth` answers it on the mesh through :class:`meshlink.rpc.RequestHandler`: a
payload that is no :data:`TruthRequest` answers ``bad_request``, one over the size limit
``too_large``, a device-layer error (an unknown label: ``UnknownElementError``) its class name
as the code, anything else ``internal``; none of them changes the world. :class:`TruthClient`
implements the same interface over the mesh, so a checker holds one ``GroundTruth`` whether
the world is in its process or elsewhere; :meth:`TruthClient.find` says whether any simulator
answers at all.
"""

from __future__ import annotations

from typing import Protocol

import anyio
import anyio.abc

from device_drivers import protocol as p
from device_drivers._errors import DeviceError, DeviceUnavailableError
from meshlink import KeySpace, Mesh, NoReplyError, RemoteError
from meshlink.rpc import DEFAULT_MAX_REQUEST_BYTES, RequestHandler, WireError, encode

from ._messages import ClockReply, SimClock, TruthReply, TruthRequest, decode_truth_reply

__all__ = ["GroundTruth", "TruthClient", "serve_truth", "truth_handler", "truth_key"]


def truth_key(keys: KeySpace) -> str:
    """``skimesh/<mesh>/sim/truth``: the queryable of the simulator's ground truth."""
    return keys.sim_truth()


class GroundTruth(Protocol):
    """A simulator's answers about its world (see :mod:`device_drivers.truth`)."""

    async def answer(self, request: TruthRequest) -> TruthReply:
        """The reply to ``request``; raises a :class:`~device_drivers.DeviceError` (e.g.
        ``UnknownElementError``) for a request it cannot answer."""
        ...


def _to_reply(exc: Exception) -> p.ErrorReply | None:
    return p.error_reply(exc) if isinstance(exc, DeviceError) else None


def truth_handler(
    truth: GroundTruth, *, max_request_bytes: int = DEFAULT_MAX_REQUEST_BYTES
) -> RequestHandler[TruthRequest, TruthReply]:
    """The RPC handler answering ``truth`` (bytes in, bytes out; never raises)."""
    return RequestHandler(
        TruthRequest,
        truth.answer,
        errors=_to_reply,
        max_request_bytes=max_request_bytes,
        error_type=p.ErrorReply,
        name="sim/truth",
    )


async def serve_truth(
    mesh: Mesh,
    truth: GroundTruth,
    *,
    max_request_bytes: int = DEFAULT_MAX_REQUEST_BYTES,
    task_status: anyio.abc.TaskStatus[None] = anyio.TASK_STATUS_IGNORED,
) -> None:
    """Serve ``truth`` on ``sim/truth`` until cancelled; started once it is routable."""
    key = truth_key(mesh.keys)
    handler = truth_handler(truth, max_request_bytes=max_request_bytes).serve_on(key)
    await mesh.serve(key, handler, task_status=task_status)


class TruthClient:
    """:class:`GroundTruth` over the mesh. A call with settling waits as long as the
    simulator settles, plus ``timeout``."""

    def __init__(self, mesh: Mesh, *, timeout: float = 5.0) -> None:
        self._mesh = mesh
        self._key = truth_key(mesh.keys)
        self.timeout = timeout

    @classmethod
    async def find(cls, mesh: Mesh, *, timeout: float = 2.0) -> tuple[TruthClient | None, str]:
        """A client if a simulator answers on ``mesh`` within ``timeout`` s, with its clock
        (``"t=12.30 s (fast)"``); else ``None`` and why."""
        client = cls(mesh, timeout=timeout)
        try:
            clock = await client.answer(SimClock())
        except DeviceUnavailableError as exc:
            return None, str(exc)
        except DeviceError as exc:
            return None, f"the simulator cannot answer: {exc}"
        client.timeout = max(client.timeout, 5.0)
        if not isinstance(clock, ClockReply):
            return None, f"the simulator answered {type(clock).__name__} to its clock"
        return client, f"t={clock.time:.2f} s ({'fast' if clock.fast else 'real time'})"

    async def answer(self, request: TruthRequest) -> TruthReply:
        wait = self.timeout + getattr(request, "settle", 0.0) + getattr(request, "rest_within", 0)
        try:
            payload = await self._mesh.request(self._key, encode(request), timeout=wait)
        except RemoteError as exc:
            raise p.error_from_reply(exc.payload) from None
        except NoReplyError:
            raise DeviceUnavailableError(f"no reply on {self._key} within {wait:g} s") from None
        try:
            return decode_truth_reply(payload)
        except WireError as exc:
            raise DeviceError(f"sim/truth: unreadable reply ({exc})") from None
