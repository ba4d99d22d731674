"""How every primitive runs a device command: deadline, cancellation, safe stop, progress.

:func:`supervise` awaits one device call and guarantees that the device is left *stopped*
whenever the call does not complete normally:

- **cancelled** (a skill stopped, a hold-condition broke, a timeout of the run): the device's
  ``stop()`` runs shielded from the cancellation (bounded by :data:`STOP_LIMIT` seconds), then
  the cancellation propagates;
- **too slow** (``timeout`` seconds of wall-clock time): stopped likewise, then
  :class:`~device_drivers.MotionTimeoutError`;
- **failed** (a :class:`~device_drivers.MotionError`: collision, grasp lost, device
  timeout): stopped (idempotent; the driver already halted), the error re-raised.
- **refused** (:class:`~device_drivers.UnreachableError`, an IK error, not a
  ``MotionError``; ``CommandError``, ``DeviceBusyError``): re-raised without a stop. The IK
  check refuses a target before anything moves (a straight move that meets it part-way is
  held by the driver itself); a stop would reset the held set-points to where the arm sags
  to, or end the motion the device is busy with.

Progress callbacks receive the fraction of a motion done, 0..1; :func:`sub_progress` maps a
step of a compound primitive into its share of the whole.
"""

from __future__ import annotations

from collections.abc import Awaitable, Callable
from typing import TypeVar

import anyio

from device_drivers import Device, MotionError, MotionTimeoutError, ProgressCallback

__all__ = ["STOP_LIMIT", "halt", "sub_progress", "supervise"]

T = TypeVar("T")

STOP_LIMIT = 2.0
"""Seconds a device gets to acknowledge ``stop()`` after a cancellation or failure."""


async def halt(*devices: Device) -> None:
    """Stop every device, shielded from cancellation, each within :data:`STOP_LIMIT` s.
    Never raises (a device that does not answer is left to its own safety logic)."""
    with anyio.CancelScope(shield=True):
        for device in devices:
            with anyio.move_on_after(STOP_LIMIT):
                try:
                    await device.stop()
                except Exception:  # stop() promises not to raise; a broken proxy might
                    continue


async def supervise(
    device: Device,
    what: str,
    call: Callable[[], Awaitable[T]],
    *,
    timeout: float | None = None,
) -> T:
    """Await ``call()`` (a command to ``device``); see the module doc. ``what`` names the
    motion in error messages, ``timeout`` is in seconds (None: the device's own limits)."""
    try:
        with anyio.fail_after(timeout):
            return await call()
    except TimeoutError:
        await halt(device)
        raise MotionTimeoutError(
            f"{what}: not done within {timeout:g} s; {device.name} was stopped"
        ) from None
    except anyio.get_cancelled_exc_class():
        await halt(device)
        raise
    except MotionError:
        await halt(device)
        raise


def sub_progress(
    progress: ProgressCallback | None, start: float, end: float
) -> ProgressCallback | None:
    """A callback reporting ``start + f * (end - start)`` to ``progress`` (None stays None)."""
    if progress is None:
        return None
    report = progress

    def scaled(fraction: float) -> None:
        report(start + max(0.0, min(1.0, fraction)) * (end - start))

    return scaled
