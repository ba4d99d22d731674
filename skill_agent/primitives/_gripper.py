"""Gripper primitives: open (release) and close (grasp). Cancellable like every primitive
(cancellation stops the gripper where it is, then propagates); widths in metres, forces in
newtons."""

from __future__ import annotations

from device_drivers import CommandError, Gripper, GripperState
from skill_agent.primitives._supervise import supervise

__all__ = ["close_gripper", "open_gripper", "release"]


async def open_gripper(
    gripper: Gripper, width: float | None = None, *, timeout: float | None = None
) -> None:
    """Open to ``width`` m between the pads (default: fully), releasing whatever is held."""
    await supervise(gripper, f"{gripper.name}: open", lambda: gripper.open(width), timeout=timeout)


async def close_gripper(
    gripper: Gripper, force: float = 20.0, *, expect: str = "", timeout: float | None = None
) -> bool:
    """Close with ``force`` N per finger until the fingers stop. Returns whether an object is
    held (attached: both pads touch it) — with ``expect``, whether *that* object (its world
    name, i.e. its world-model label) is held."""
    state: GripperState = await supervise(
        gripper, f"{gripper.name}: close", lambda: gripper.close(force), timeout=timeout
    )
    return state.holding == expect if expect else bool(state.holding)


async def release(gripper: Gripper, *, extra: float = 0.02, timeout: float | None = None) -> None:
    """Let go of the held object by opening only ``extra`` m wider than the fingers stand now
    (less sweep than a full opening, so neighbours in a tight box are not pushed); fully, if
    the gripper cannot open that wide."""
    state = await gripper.state()
    try:
        await open_gripper(gripper, state.opening + extra, timeout=timeout)
    except CommandError:  # wider than it opens: nothing moved
        await open_gripper(gripper, timeout=timeout)
