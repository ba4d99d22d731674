"""Helpers the standard skills share: world-model reads, element geometry, progress relay.

Geometry read from the world model is in the world frame (``wm.spatial`` chains frames), in
metres; an element's pose is the centre of its bounding volume.
"""

from __future__ import annotations

from collections.abc import Awaitable, Callable
from typing import TypeVar, cast

import anyio
import anyio.lowlevel
from anyio.abc import TaskGroup

from device_drivers import Device, ProgressCallback
from skill_agent._errors import SkillFailure
from skill_agent._skill import SkillContext
from skill_agent.primitives._grasp import extents
from skill_agent.primitives.poses import Vec3, to_wm_pose
from wm_store import WmClient, WmError, display_name
from wm_store.ontology import Prop
from wm_store.protocol import Element, Op, Pose, UpdateElement, Value
from wm_store.reasoners import MissingDataError, Transform

__all__ = [
    "Geometry",
    "carried_ops",
    "device",
    "element_id",
    "failure",
    "float_param",
    "geometry",
    "tracked",
    "wm_of",
    "world_transform",
]

T = TypeVar("T")
PROGRESS_STEP = 0.02
"""Smallest change of a run's fraction done that is published as a progress event."""
D = TypeVar("D", bound=Device)


def device(ctx: SkillContext, param: str, kind: type[D]) -> D:
    """The driver bound to hardware parameter ``param``, checked against a device Protocol
    (``Arm``, ``Gripper``, ``MobileBase``, ``ObjectSensor``, ``Appliance``)."""
    return ctx.device(param, kind)


def wm_of(ctx: SkillContext) -> WmClient:
    """The run's world-model client (``SkillContext.wm`` is typed ``object``)."""
    return cast(WmClient, ctx.wm)


def element_id(ctx: SkillContext, param: str) -> str:
    """The element id bound to ``param``; SkillFailure if it is unbound."""
    value = ctx.params.get(param)
    if not isinstance(value, str):
        raise SkillFailure(f"{ctx.description.name}: parameter {param!r} is not bound")
    return value


def float_param(ctx: SkillContext, name: str) -> float:
    value: Value = ctx.params.get(name)
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise SkillFailure(f"{ctx.description.name}: parameter {name!r} is {value!r}, no number")
    return float(value)


def world_transform(wm: WmClient, element: str) -> Transform | None:
    """The element's world pose (centre), or None if the world model cannot tell."""
    try:
        return wm.spatial.world_transform(element)
    except (MissingDataError, WmError):
        return None


def carried_ops(wm: WmClient, root: str, motion: Transform, *, with_root: bool = False) -> list[Op]:
    """Ops applying the rigid ``motion`` (world frame) to every spatial descendant of ``root``
    that has a world-frame pose (and to ``root`` itself ``with_root``): what a robot carries
    when it drives, what lies in a drawer when it slides. Each pose is replaced and its old
    observations dropped (they saw the element where it was)."""
    ops: list[Op] = []
    todo = [root] if with_root else [child.id for child in wm.get_children(root)]
    while todo:
        element = todo.pop()
        todo += [child.id for child in wm.get_children(element)]
        pose = wm.get_element(element).properties.get(Prop.pose)
        if isinstance(pose, Pose) and not (pose.frame or pose.position.frame):
            moved = motion.compose(world_transform(wm, element) or Transform())
            ops.append(UpdateElement(id=element, remove=[Prop.pose]))
            ops.append(UpdateElement(id=element, properties={Prop.pose: to_wm_pose(moved)}))
    return ops


class Geometry:
    """What the world model knows of an element's placement and extent."""

    def __init__(self, element: Element, pose: Transform | None, size: Value) -> None:
        self.element, self.pose, self.size = element, pose, size
        self.extents: Vec3 | None = extents(size)

    @property
    def label(self) -> str:
        """The label the devices know the element by (its id when it has none)."""
        return self.element.label or self.element.id

    @property
    def name(self) -> str:
        """How messages name the element (:func:`wm_store.display_name`)."""
        return display_name(self.element)

    def require(self, what: str) -> tuple[Transform, Vec3]:
        """Pose and extents, or SkillFailure naming what is missing."""
        if self.pose is None or self.extents is None:
            missing = "pose" if self.pose is None else "size"
            raise SkillFailure(f"{what}: the world model has no {missing} of {self.element.id}")
        return self.pose, self.extents

    def grasp_pose(self) -> Pose | None:
        value = self.element.properties.get(Prop.graspPose)
        return value if isinstance(value, Pose) else None

    def grasp_width(self) -> float | None:
        value = self.element.properties.get(Prop.graspWidth)
        ok = isinstance(value, int | float) and not isinstance(value, bool)
        return float(value) if ok else None  # type: ignore[arg-type]  # checked just above


def geometry(wm: WmClient, element: str) -> Geometry:
    e = wm.get_element(element)
    return Geometry(e, world_transform(wm, element), e.properties.get(Prop.size))


def failure(skill: str, exc: Exception) -> SkillFailure:
    """A device or planning error as the skill's failure, message kept."""
    return SkillFailure(f"{skill}: {type(exc).__name__}: {exc}")


async def tracked(
    ctx: SkillContext,
    message: str,
    call: Callable[[ProgressCallback], Awaitable[T]],
    *,
    step: str,
    start: float = 0.0,
    end: float = 1.0,
) -> T:
    """Await ``call(progress)`` (a primitive taking a progress callback) while its reports
    become run progress events (``start..end`` of the run, message ``message``). A paused
    run holds before the call (its checkpoint); a call under way is held by its device. The
    callback stays cheap and synchronous; a task publishes the latest fraction, coalescing
    reports that come faster. Errors of ``call`` propagate as themselves (not as a group)."""
    latest = [start]
    box = [anyio.Event()]

    def callback(fraction: float) -> None:
        latest[0] = start + max(0.0, min(1.0, fraction)) * (end - start)
        box[0].set()

    async def publish() -> None:
        sent = start
        while True:
            await box[0].wait()
            box[0] = anyio.Event()
            if abs(latest[0] - sent) >= PROGRESS_STEP:
                sent = latest[0]
                await ctx.progress(message, fraction=sent, step=step)

    result: list[T] = []

    async def work(tg: TaskGroup) -> None:
        result.append(await call(callback))
        tg.cancel_scope.cancel()

    await ctx.checkpoint()  # a paused run issues no further motion
    await ctx.progress(message, fraction=start, step=step)
    try:
        async with anyio.create_task_group() as tg:
            tg.start_soon(publish)
            tg.start_soon(work, tg)
    except BaseExceptionGroup as group:
        raise _single(group) from None
    if not result:  # cancelled from outside: the cancellation is already on its way
        await anyio.lowlevel.checkpoint()
        raise SkillFailure(f"{ctx.description.name}: {message}: interrupted")
    await ctx.progress(message, fraction=end, step=step)
    return result[0]


def _single(group: BaseExceptionGroup[BaseException]) -> BaseException:
    """The one real error in a task group's exception group (cancellations dropped)."""
    found: list[BaseException] = []
    stack: list[BaseException] = [group]
    while stack:
        exc = stack.pop()
        if isinstance(exc, BaseExceptionGroup):
            stack.extend(exc.exceptions)
        elif not isinstance(exc, anyio.get_cancelled_exc_class()):
            found.append(exc)
    return found[0] if len(found) == 1 else group
