"""Readiness probes: one attempt each, a reason when the component is not ready yet.

Real health checks where the component answers one: the router accepts a TCP connection, the
store answers an info request, the simulator's devices answer ``Describe``, each agent's
liveliness token is alive (declared once it registered in the world model), the task agent
answers a task listing.
"""

from __future__ import annotations

import anyio

from device_drivers import DeviceError
from meshlink import Mesh, MeshlinkError
from task_agent import TaskError
from wm_store import WmError

from ..errors import SkimeshError
from ._plan import Component

__all__ = ["ATTEMPT", "probe"]

ATTEMPT = 1.0
"""Seconds one probe may take."""


async def probe(component: Component, mesh: Mesh | None) -> str:
    """``""`` when ``component`` is ready, else why not (one attempt, at most :data:`ATTEMPT`
    seconds)."""
    kind = component.ready[0] if component.ready else ""
    if kind == "tcp":
        address, port = component.ready[1], int(component.ready[2])
        try:
            with anyio.fail_after(ATTEMPT):
                stream = await anyio.connect_tcp(address.strip("[]"), port)
        except (OSError, TimeoutError):
            return f"nothing listens on {address}:{port} yet"
        await stream.aclose()
        return ""
    if not kind:
        return ""
    if mesh is None:
        return "no mesh session yet"
    try:
        return await _over_mesh(kind, component.ready[1:], mesh)
    except (MeshlinkError, WmError, TaskError, DeviceError, SkimeshError, TimeoutError) as e:
        return str(e) or type(e).__name__


async def _over_mesh(kind: str, names: tuple[str, ...], mesh: Mesh) -> str:
    if kind == "store":
        from wm_store import ZenohTransport
        from wm_store.protocol import Info, InfoReply

        reply = await ZenohTransport(mesh).request(Info(), timeout=ATTEMPT)
        return "" if isinstance(reply, InfoReply) else f"the store answered {reply!r}"
    if kind == "devices":
        from device_drivers.remote import connect_devices

        found = await connect_devices(mesh, timeout=ATTEMPT)
        return "" if found else "no device answers yet"
    if kind == "agents":
        from skill_agent.client import list_agents

        alive = set(await list_agents(mesh, timeout=ATTEMPT))
        missing = [n for n in names if n not in alive]
        return f"not alive yet: {', '.join(missing)}" if missing else ""
    if kind == "tasks":
        from task_agent import TaskClient

        await TaskClient(mesh, timeout=ATTEMPT).list()
        return ""
    if kind == "eventlog":
        from ..eventlog import EventLogClient

        await EventLogClient(mesh, timeout=ATTEMPT).info()
        return ""
    raise ValueError(f"unknown probe {kind!r}")
