"""The devices of a paused run: :class:`DeviceHold` pauses and resumes them.

A run's devices are the drivers of the resources it locked (its hardware parameters; a
composite's sub-runs borrow from these) that are :class:`~device_drivers.Pausable`. Pausing
them brings their motions to rest on their paths; the calls run side by side, each within
:data:`HOLD_LIMIT` seconds. A device that does not answer, or refuses, is logged and left to
the run's checkpoints; it never fails the pause or the resume.
"""

from __future__ import annotations

import logging
from collections.abc import Awaitable, Callable, Mapping, Sequence

import anyio

from device_drivers import DeviceError, Pausable

__all__ = ["HOLD_LIMIT", "DeviceHold"]

_log = logging.getLogger(__name__)

HOLD_LIMIT = 3.0
"""Seconds a device gets to answer a pause (it answers once at rest) or a resume: the
agent answers a pause within it, inside the 5 s a client waits by default."""


class DeviceHold:
    """The pausable devices of one run, and which of them it holds now."""

    def __init__(self, run_id: str, devices: Mapping[str, object], resources: Sequence[str]):
        self.run_id = run_id
        self._devices = devices
        self._resources = resources
        self.held: list[Pausable] = []

    def pausable(self) -> list[Pausable]:
        """The run's devices that can be paused, each once, in resource order."""
        found: list[Pausable] = []
        for resource in self._resources:
            device = self._devices.get(resource)
            if isinstance(device, Pausable) and all(device is not d for d in found):
                found.append(device)
        return found

    async def pause(self) -> list[str]:
        """Pause the run's devices; returns once each is at rest (or gave up), with the
        names of those that answered."""
        self.held = devices = self.pausable()
        return await self._each(devices, lambda device: device.pause(), "pause")

    async def resume(self) -> None:
        """Resume what :meth:`pause` held (nothing if nothing is held); shielded, so a run
        that ends never leaves a device held."""
        devices, self.held = self.held, []
        if devices:
            with anyio.CancelScope(shield=True):
                await self._each(devices, lambda device: device.resume(), "resume")

    async def _each(
        self, devices: list[Pausable], call: Callable[[Pausable], Awaitable[None]], what: str
    ) -> list[str]:
        """``call`` every device side by side; the names of those that answered."""
        answered: list[str] = []

        async def one(device: Pausable) -> None:
            with anyio.move_on_after(HOLD_LIMIT) as scope:
                try:
                    await call(device)
                    answered.append(_name(device))
                except DeviceError as exc:
                    _log.warning("run %s: cannot %s %s: %s", self.run_id, what, _name(device), exc)
            if scope.cancelled_caught:
                _log.warning(
                    "run %s: %s did not answer a %s within %g s",
                    self.run_id,
                    _name(device),
                    what,
                    HOLD_LIMIT,
                )

        async with anyio.create_task_group() as tg:
            for device in devices:
                tg.start_soon(one, device)
        return sorted(answered)


def _name(device: object) -> str:
    return str(getattr(device, "name", device))
