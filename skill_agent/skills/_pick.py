"""``pick`` (from a box, a surface, a tray) and ``take_out`` (from an appliance whose door is
open): grasp an object and lift it.

``pre_sense`` locates the object (``locate``). ``execute`` plans the grasp from the object's
pose, size and grasp data (:func:`~skill_agent.primitives.plan_grasp`; no grasp fits: it fails
before anything moves), opens the gripper, brings the arm to its home posture (the arm's
``jointPositions``: a known IK branch), approaches (a free move to a pre-grasp pose
``approach`` m back, then a straight move in), closes and lifts. ``post_sense`` verifies with
the gripper's own report that it holds *this* object (both pads on it), else the run fails
with "grasp failed: ..." and the gripper opens.
The prediction, ``contain(gripper, object)``, takes the object out of its holder in the world
model. A stop halts the arm; the gripper keeps a grasped object and opens otherwise.
"""

from __future__ import annotations

from collections.abc import Awaitable, Callable
from typing import ClassVar

from device_drivers import Arm, DeviceError, GraspLostError, ProgressCallback, WorldPose
from skill_agent._errors import SkillFailure
from skill_agent._skill import Skill, SkillContext
from skill_agent.primitives._arm import approach, retreat
from skill_agent.primitives._grasp import Grasp, NoGraspError, plan_grasp
from skill_agent.primitives._gripper import close_gripper, open_gripper
from skill_agent.primitives.poses import Vec3
from skill_agent.protocol._skills import ParamSpec, RelationCond, SkillDescription
from skill_agent.skills._locate import locate_object
from skill_agent.skills._manipulation import (
    UP,
    arm_of,
    depth_inside,
    front_of,
    go_home,
    gripper_of,
    make_safe,
)
from skill_agent.skills._params import (
    ARM,
    GRIPPER,
    LOCATION,
    OBJECT,
    PLATFORM,
    ROBOT,
    SENSOR,
    at,
    contains,
    door_is,
    empty,
    is_not,
    offline,
)
from skill_agent.skills._support import element_id, failure, float_param, geometry, tracked, wm_of
from wm_store.ontology import Cls, Rel

__all__ = ["TAKE_OUT_RAISE", "Lift", "Pick", "TakeOut"]

Lift = list[tuple[Vec3, float]]
"""Straight moves after a grasp: (direction in the world, distance in m)."""
TAKE_OUT_RAISE = 0.015
"""How far (m) an object is raised off an appliance's floor before it is pulled out."""

_TUNING = [
    offline("force", "float", 20.0, "squeeze force per finger, N"),
    offline("approach", "float", 0.10, "pre-grasp distance back along the approach, m"),
    offline("lift", "float", 0.12, "how far the grasped object is lifted (or pulled out), m"),
]


def _straight(
    arm: Arm, distance: float, direction: Vec3
) -> Callable[[ProgressCallback], Awaitable[WorldPose]]:
    """A straight move of ``distance`` m along ``direction``, waiting for a progress callback."""
    return lambda cb: retreat(arm, distance, direction=direction, progress=cb)


class Pick(Skill):
    """Grasp an object from what holds it and lift it."""

    description = SkillDescription(
        name="pick",
        skill_type="pick",
        doc="Locate an object, grasp it with an empty gripper and lift it out of its holder "
        "(a box, a surface, a tray) at the robot's location.",
        parameters=[
            OBJECT,
            ParamSpec(name="holder", type=Cls.PhysicalObject, doc="what holds it now"),
            LOCATION,
            ROBOT,
            ARM,
            GRIPPER,
            SENSOR,
            PLATFORM,
            *_TUNING,
        ],
        pre=[
            empty("gripper"),
            contains("holder", "object"),
            is_not("holder", Cls.Appliance),
            at("robot", "location"),
            at("holder", "location"),
        ],
        hold=[contains("holder", "object")],
        post=[RelationCond(subject="gripper", predicate=Rel.contain, object="object")],
        duration=4.0,
    )
    senses = ("object",)
    success_probability = 0.9
    holder_param: ClassVar[str] = "holder"

    def __init__(self) -> None:
        self.lost = ""

    def travel(self, ctx: SkillContext, tcp: WorldPose) -> tuple[Vec3 | None, float, Lift]:
        """For a grasp at ``tcp``: the approach direction (None: the grasp's own axis), the
        pre-grasp distance (m) and the lift: straight moves (direction, m) after the grasp."""
        return None, float_param(ctx, "approach"), [(UP, float_param(ctx, "lift"))]

    async def pre_sense(self, ctx: SkillContext) -> None:
        await locate_object(ctx)

    async def execute(self, ctx: SkillContext) -> None:
        wm, arm, gripper = wm_of(ctx), arm_of(ctx), gripper_of(ctx)
        obj = geometry(wm, element_id(ctx, "object"))
        pose, _ = obj.require("pick")
        holder = geometry(wm, element_id(ctx, self.holder_param))
        around = (holder.pose, holder.extents) if holder.pose and holder.extents else None

        def plan(current: WorldPose) -> Grasp:
            try:
                return plan_grasp(
                    pose,
                    obj.size,
                    grasp_pose=obj.grasp_pose(),
                    grasp_width=obj.grasp_width(),
                    holder=around,
                    current=current,
                )
            except NoGraspError as exc:
                raise SkillFailure(f"pick: {obj.name}: {exc}") from exc

        plan((await arm.state()).tcp)  # no grasp: fail before anything moves
        try:
            await open_gripper(gripper)
            await go_home(ctx, arm)
            grasp = plan((await arm.state()).tcp)  # the finger sign nearest the home posture
            inward, offset, lift = self.travel(ctx, grasp.tcp)
            await tracked(
                ctx,
                f"approaching {obj.name} ({grasp.strategy} grasp)",
                lambda cb: approach(arm, grasp.tcp, offset, direction=inward, progress=cb),
                step="approach",
                end=0.6,
            )
            await ctx.checkpoint()
            await ctx.progress(f"closing on {obj.name}", step="grasp", fraction=0.6)
            await close_gripper(gripper, float_param(ctx, "force"), expect=obj.label)
            for k, (direction, distance) in enumerate(lift):
                await tracked(
                    ctx,
                    f"lifting {obj.name}" if k == 0 else f"pulling {obj.name} out",
                    _straight(arm, distance, direction),
                    step="lift",
                    start=0.7 + 0.3 * k / len(lift),
                    end=0.7 + 0.3 * (k + 1) / len(lift),
                )
        except GraspLostError as exc:  # slipped while lifting: post_sense tells
            self.lost = str(exc)
        except (DeviceError, ValueError) as exc:
            raise failure("pick", exc) from exc

    async def post_sense(self, ctx: SkillContext) -> None:
        gripper = gripper_of(ctx)
        label = wm_of(ctx).get_element(element_id(ctx, "object")).label
        state = await gripper.state()
        if state.holding == label:
            await ctx.progress(f"holding {label} (opening {state.opening * 1000:.1f} mm)")
            return
        await open_gripper(gripper)
        why = f"; lost while lifting: {self.lost}" if self.lost else ""
        raise SkillFailure(
            f"grasp failed: {gripper.name} holds {state.holding or 'nothing'}, not {label} "
            f"({state.pads_in_contact} pad(s) in contact){why}"
        )

    async def on_preempt(self, ctx: SkillContext) -> None:
        await make_safe(ctx)


class TakeOut(Pick):
    """Grasp an object inside an appliance (through its open door) and pull it out."""

    description = SkillDescription(
        name="take_out",
        skill_type="pick",
        doc="Locate an object inside an appliance whose door is open, grasp it through the "
        "front and pull it out.",
        parameters=[
            OBJECT,
            ParamSpec(name="appliance", type=Cls.Appliance, doc="the appliance it is in"),
            LOCATION,
            ROBOT,
            ARM,
            GRIPPER,
            SENSOR,
            PLATFORM,
            *_TUNING,
        ],
        pre=[
            empty("gripper"),
            contains("appliance", "object"),
            door_is("appliance", True),
            at("robot", "location"),
            at("appliance", "location"),
        ],
        hold=[contains("appliance", "object"), door_is("appliance", True)],
        post=[RelationCond(subject="gripper", predicate=Rel.contain, object="object")],
        duration=5.0,
    )
    holder_param = "appliance"

    def travel(self, ctx: SkillContext, tcp: WorldPose) -> tuple[Vec3 | None, float, Lift]:
        """In through the front from ``approach`` m back; out: 1.5 cm up, then along the
        front until ``lift`` m clear of it."""
        wm, appliance = wm_of(ctx), element_id(ctx, "appliance")
        front, inside = front_of(wm, appliance), depth_inside(wm, appliance, tcp)
        inward: Vec3 = (-front[0], -front[1], 0.0)
        out: Lift = [(UP, TAKE_OUT_RAISE), (front, inside + float_param(ctx, "lift"))]
        return inward, float_param(ctx, "approach"), out
