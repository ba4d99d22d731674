"""``open_door`` / ``close_door`` done by a robot arm: swing a hinged door by its handle.

The door element's pose (world) is the centre of the closed panel, its x axis pointing out of
the front, its y axis from the hinge to the free edge; its size is (thickness, width,
height) (``scenario.wm`` writes them). The handle is a horizontal bar
``handle_standoff`` m out of the outer face, ``handle_inset`` m in from the free edge, at mid
height (the scene's motorless doors: ``ApplianceEntry.door_motor = false``). ``open_door``
grips the bar (tcp pointing at the face, fingers closing vertically on it), pulls it along
the arc about the hinge to ``open_angle`` rad in straight segments of at most ``step`` rad,
lets go and backs off; ``close_door`` grips it where the open door has it and pushes it back
along the arc.

Verification is the arm's: a door that does not follow stops the arm (the motion fails with a
collision, a time-out or an unreachable point) and the run fails. The appliance's own state
is not visible to this agent. For a motorised door whose motor holds it (the simulated smart
microwave), use the appliance agent's skills of the same names instead.
"""

from __future__ import annotations

import math

from device_drivers import Arm, DeviceError, ProgressCallback, WorldPose
from scenario import DOOR_HANDLE_INSET, DOOR_HANDLE_STANDOFF
from skill_agent._skill import Skill, SkillContext
from skill_agent.primitives._arm import approach, move_cartesian, retreat
from skill_agent.primitives._gripper import close_gripper, open_gripper
from skill_agent.primitives.poses import Vec3, axis, cross
from skill_agent.protocol._skills import Condition, ParamSpec, RelationCond, SkillDescription
from skill_agent.skills._manipulation import arm_of, gripper_of, make_safe
from skill_agent.skills._params import ARM, GRIPPER, LOCATION, ROBOT, at, door_is, empty, offline
from skill_agent.skills._support import element_id, failure, float_param, geometry, tracked, wm_of
from wm_store.ontology import Cls, Rel
from wm_store.reasoners import Transform, quat_from_axes

__all__ = ["ArmCloseDoor", "ArmOpenDoor", "handle_pose"]


def handle_pose(
    door: Transform,
    size: tuple[float, float, float],
    angle: float,
    inset: float,
    standoff: float = 0.0,
) -> WorldPose:
    """The tcp at the handle of a door opened by ``angle`` rad (0 = closed): ``standoff`` m
    out of the outer face (the bar of a handle), pointing at the face, fingers closing
    vertically (world frame, m)."""
    x_d, y_d, z_d = (axis(door.rotation, i) for i in range(3))
    c = door.translation
    half_w = size[1] / 2
    hinge = tuple(c[i] - y_d[i] * half_w for i in range(3))
    # opening turns y_d (hinge -> free edge) towards x_d (out of the front)
    ca, sa = math.cos(angle), math.sin(angle)
    along = tuple(y_d[i] * ca + x_d[i] * sa for i in range(3))
    normal = tuple(x_d[i] * ca - y_d[i] * sa for i in range(3))
    reach = size[1] - inset
    out = size[0] / 2 + standoff
    p = tuple(hinge[i] + along[i] * reach + normal[i] * out for i in range(3))
    inward: Vec3 = (-normal[0], -normal[1], -normal[2])
    q = quat_from_axes(cross(z_d, inward), z_d, inward)
    return WorldPose(p[0], p[1], p[2], *q)


_PARAMS = [
    ParamSpec(name="appliance", type=Cls.Appliance, doc="the appliance whose door it is"),
    ParamSpec(name="door", type=Cls.Door, doc="the door"),
    LOCATION,
    ROBOT,
    ARM,
    GRIPPER,
    offline("open_angle", "float", 1.4, "how far the door is swung open, rad"),
    offline("step", "float", 0.15, "largest arc step of one straight motion, rad"),
    offline("handle_inset", "float", DOOR_HANDLE_INSET, "handle distance from the free edge, m"),
    offline(
        "handle_standoff", "float", DOOR_HANDLE_STANDOFF, "how far the handle bar stands out, m"
    ),
]
_WHERE: list[Condition] = [
    RelationCond(subject="appliance", predicate=Rel.hasA, object="door"),
    at("robot", "location"),
    at("appliance", "location"),
    empty("gripper"),
]


class _ArmDoor(Skill):
    opening: bool = True

    async def execute(self, ctx: SkillContext) -> None:
        wm, arm, gripper = wm_of(ctx), arm_of(ctx), gripper_of(ctx)
        door = geometry(wm, element_id(ctx, "door"))
        pose, size = door.require(ctx.description.name)
        full = float_param(ctx, "open_angle")
        start, end = (0.0, full) if self.opening else (full, 0.0)
        inset = float_param(ctx, "handle_inset")
        n = max(1, math.ceil(abs(end - start) / float_param(ctx, "step")))
        standoff = float_param(ctx, "handle_standoff")
        arc = [
            handle_pose(pose, size, start + (end - start) * k / n, inset, standoff)
            for k in range(n + 1)
        ]
        try:
            await open_gripper(gripper)
            await approach(arm, arc[0], 0.08)
            await close_gripper(gripper)
            await tracked(ctx, "swinging the door", lambda cb: _sweep(arm, arc[1:], cb), step="arc")
            await open_gripper(gripper)
            await retreat(arm, 0.08)
        except DeviceError as exc:
            raise failure(ctx.description.name, exc) from exc

    async def on_preempt(self, ctx: SkillContext) -> None:
        await make_safe(ctx)


async def _sweep(arm: Arm, points: list[WorldPose], progress: ProgressCallback) -> None:
    for k, point in enumerate(points):
        await move_cartesian(arm, point, speed=0.08)
        progress((k + 1) / len(points))


class ArmOpenDoor(_ArmDoor):
    description = SkillDescription(
        name="open_door",
        skill_type="open_door",
        doc="Open an appliance's hinged door with the arm (pull the handle along the arc).",
        parameters=_PARAMS,
        pre=[*_WHERE, door_is("appliance", False)],
        post=[door_is("appliance", True)],
        duration=6.0,
    )
    opening = True


class ArmCloseDoor(_ArmDoor):
    description = SkillDescription(
        name="close_door",
        skill_type="close_door",
        doc="Close an appliance's open hinged door with the arm (push it along the arc).",
        parameters=_PARAMS,
        pre=[*_WHERE, door_is("appliance", True)],
        post=[door_is("appliance", False)],
        duration=6.0,
    )
    opening = False
