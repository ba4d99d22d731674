"""``place``: put the held object into a container the robot carries (e.g. its kit box);
``place_on`` (:class:`PlaceOn`, the same skill type): put it down on a surface at the robot's
location (a shelf board, a table). Its variants ``serve`` (onto a tray) and ``put_in`` (into
an appliance) are in :mod:`skill_agent.skills`.

``execute`` first checks the gripper still holds the object, finds free spots on the target
(in a container: on its floor, :func:`~skill_agent.primitives.free_spots`, nearest its centre
first; on a surface: on its top, :func:`~skill_agent.primitives.surface_spots`, ``edge`` m in
from its edges, nearest the robot first; both away from what the world model says is already
there), carries the object through the arm's home posture, computes where the tcp
must go for the object's bottom to be ``drop`` m above a spot
(:func:`~skill_agent.primitives.release_pose`, from the grasp the object was picked with),
approaches (the next spot if one is out of reach, or if the arm has no collision-free joint
move to it), releases (opening just wider than the object) and retreats. An arm
that cannot reach all the way down (a kit box low behind its shoulder) releases where it
stopped if the object is already below the target's rim (a surface: its top), straight above
the spot.

``post_sense`` is the honest check, with the ground truth the sensors report:

- the object was lost on the way (the arm reports it, or the gripper holds nothing before the
  release): the run fails, "dropped"; the world model is corrected (the gripper no longer
  holds it; if a sensor sees it, its pose and the container or surface it fell into);
- after the release a sensor sees the object outside the target (for a surface: not on its
  top, or inside something standing on it, such as a part box): the run fails likewise;
- a sensor sees it there: its pose is written, the prediction ``contain(target, object)`` is
  committed (the world model's scene tree puts what rests on a surface under it, as a shelf
  contains its boxes). When no sensor sees the target (e.g. a kit box on the robot's own
  deck behind its camera) the release pose is trusted and the progress says so.

Why two skills, not one ``place`` with a container-or-surface target: a planner needs one
parameter class and one set of pre-conditions per action. A carried container needs
``contain(robot, container)``; a surface needs the robot ``at`` the location that contains
it; a disjunction of the two would be run-time only, and the planner could no longer use
``place`` at all. Both share this class's execution and checks (the target's class chooses
floor or top).
"""

from __future__ import annotations

import math
from typing import ClassVar

from device_drivers import CollisionError, DeviceError, GraspLostError, UnreachableError, WorldPose
from skill_agent._errors import SkillFailure
from skill_agent._skill import Skill, SkillContext
from skill_agent.primitives._arm import approach, retreat
from skill_agent.primitives._grasp import (
    NoGraspError,
    extents,
    footprint_radius,
    free_spots,
    plan_grasp,
    release_pose,
    surface_spots,
)
from skill_agent.primitives._gripper import release
from skill_agent.primitives.poses import Vec3, to_transform
from skill_agent.protocol._skills import ParamSpec, SkillDescription
from skill_agent.skills._manipulation import UP, arm_of, go_home, gripper_of, make_safe
from skill_agent.skills._params import (
    ARM,
    GRIPPER,
    OBJECT,
    PLATFORM,
    ROBOT,
    SENSOR,
    at,
    contains,
    not_full,
    offline,
)
from skill_agent.skills._sensing import (
    containing,
    lies_in,
    look,
    move_ops,
    observation_ops,
    sensors_of,
)
from skill_agent.skills._support import (
    element_id,
    failure,
    float_param,
    geometry,
    tracked,
    wm_of,
    world_transform,
)
from wm_store import WmClient
from wm_store.ontology import Cls, Prop, Rel
from wm_store.protocol import Op
from wm_store.reasoners import Transform

__all__ = ["DEVICES", "RIM_SLACK", "SPOTS_TRIED", "TUNING", "Place", "PlaceOn", "is_surface"]

DEVICES = [ROBOT, ARM, GRIPPER, SENSOR, PLATFORM]
SPOTS_TRIED = 4
"""Free spots tried, nearest the target's centre first, before the place fails."""
RIM_SLACK = 0.01
"""An arm stopped short may release when the object's bottom is at most this far above the
target's rim (m), straight above the spot."""
TUNING = [
    offline("drop", "float", 0.02, "height of the object's bottom above the floor at release, m"),
    offline("approach", "float", 0.10, "pre-place distance back along the approach, m"),
    offline("wall", "float", 0.008, "wall and floor thickness of the target, m"),
]


class Place(Skill):
    """Put the held object into a container the robot carries."""

    description = SkillDescription(
        name="place",
        skill_type="place",
        doc="Put the held object down into a container the robot carries (its kit box).",
        parameters=[
            OBJECT,
            ParamSpec(name="container", type=Cls.Container, doc="where it goes"),
            *DEVICES,
            *TUNING,
        ],
        pre=[contains("gripper", "object"), contains("robot", "container"), not_full("container")],
        hold=[contains("gripper", "object")],
        post=[contains("container", "object"), contains("gripper", "object", holds=False)],
        duration=4.0,
    )
    success_probability = 0.95
    target_param: ClassVar[str] = "container"

    def __init__(self) -> None:
        self.dropped = ""

    def travel(self, ctx: SkillContext, goal: WorldPose) -> tuple[Vec3 | None, float, Vec3, float]:
        """For a release at ``goal``: approach direction (None: down the tcp axis) and
        distance (m), retreat direction and distance (m)."""
        offset = float_param(ctx, "approach")
        return None, offset, UP, offset

    async def execute(self, ctx: SkillContext) -> None:
        wm, arm, gripper = wm_of(ctx), arm_of(ctx), gripper_of(ctx)
        obj = geometry(wm, element_id(ctx, "object"))
        target_id = element_id(ctx, self.target_param)
        target = geometry(wm, target_id)
        if (await gripper.state()).holding != obj.label:
            self.dropped = f"{gripper.name} no longer holds it before the place began"
            return
        box_pose, box_ext = target.require("place")
        obj_pose, obj_ext = obj.require("place")
        tcp_now = (await arm.state()).tcp
        try:
            grasp = plan_grasp(
                obj_pose,
                obj.size,
                grasp_pose=obj.grasp_pose(),
                grasp_width=obj.grasp_width(),
                current=tcp_now,
            )
        except NoGraspError as exc:
            raise SkillFailure(f"place: cannot tell how {obj.name} is held: {exc}") from exc
        radius, occupied = footprint_radius(obj.size), _occupied(wm, target_id, obj.element.id)
        if is_surface(wm, target_id):
            robot = world_transform(wm, element_id(ctx, "robot"))
            near = robot.translation if robot is not None else (tcp_now.x, tcp_now.y, tcp_now.z)
            edge = float_param(ctx, "edge")
            spots = surface_spots(box_pose, box_ext, radius, occupied, edge=edge, near=near)
        else:
            spots = free_spots(box_pose, box_ext, radius, occupied, wall=float_param(ctx, "wall"))
        spots = spots[:SPOTS_TRIED]
        if not spots:
            raise SkillFailure(f"place: no free spot for {obj.name} in {target.name}")
        drop = float_param(ctx, "drop")
        rim = box_pose.translation[2] + box_ext[2] / 2
        try:
            await go_home(ctx, arm)
        except GraspLostError as exc:
            self.dropped = str(exc)
            return
        except (DeviceError, ValueError) as exc:
            raise failure("place", exc) from exc
        why, goal = "", tcp_now
        for k, spot in enumerate(spots):
            goal = release_pose(
                tcp_now, grasp.object_in_tcp, (spot[0], spot[1], spot[2] + drop), obj_ext[2]
            )
            try:
                why = await self._bring(ctx, goal, grasp.object_in_tcp, obj_ext[2], rim)
            except GraspLostError as exc:
                self.dropped = str(exc)
                return
            if not why:
                break
            await ctx.progress(f"spot {k + 1} of {len(spots)} out of reach: {why}", step="approach")
        else:
            raise SkillFailure(f"place: no spot in {target.name} within reach: {why}")
        _, _, back, distance = self.travel(ctx, goal)
        try:
            await ctx.checkpoint()
            await ctx.progress(f"releasing {obj.name}", step="release", fraction=0.7)
            await release(gripper)
            await tracked(
                ctx,
                "retreating",
                lambda cb: retreat(arm, distance, direction=back, progress=cb),
                step="retreat",
                start=0.8,
            )
        except (DeviceError, ValueError) as exc:  # released: post_sense judges the place
            await ctx.progress(f"could not back off after the release: {exc}", step="retreat")
            return
        try:
            await go_home(ctx, arm)
        except (DeviceError, ValueError) as exc:
            await ctx.progress(f"could not go home after the release: {exc}", step="home")

    async def _bring(
        self,
        ctx: SkillContext,
        goal: WorldPose,
        object_in_tcp: Transform,
        height: float,
        rim: float,
    ) -> str:
        """Approach the release pose ``goal``; "" when the object may be released (there, or
        where the arm stopped, if the object is already down at the rim, straight above the
        spot), else why not. GraspLostError propagates."""
        arm = arm_of(ctx)
        inward, offset, _, _ = self.travel(ctx, goal)
        try:
            await tracked(
                ctx,
                f"bringing {wm_of(ctx).get_element(element_id(ctx, 'object')).label} down",
                lambda cb: approach(arm, goal, offset, direction=inward, progress=cb),
                step="approach",
                end=0.7,
            )
            return ""
        except (UnreachableError, CollisionError) as exc:  # the arm could not go all the way
            tcp = (await arm.state()).tcp
            bottom = to_transform(tcp).compose(object_in_tcp).translation[2] - height / 2
            if bottom < rim + RIM_SLACK and math.hypot(tcp.x - goal.x, tcp.y - goal.y) < 0.01:
                side = "below" if bottom < rim else "above"
                await ctx.progress(
                    f"the arm stops short; releasing with the object's bottom "
                    f"{abs(bottom - rim) * 1000:.0f} mm {side} the rim",
                    step="release",
                )
                return ""
            return str(exc)
        except GraspLostError:
            raise
        except (DeviceError, ValueError) as exc:
            raise failure("place", exc) from exc

    async def post_sense(self, ctx: SkillContext) -> None:
        wm, gripper = wm_of(ctx), gripper_of(ctx)
        obj, target = element_id(ctx, "object"), element_id(ctx, self.target_param)
        label = wm.get_element(obj).label
        holding = (await gripper.state()).holding
        if not self.dropped and holding == label:
            raise SkillFailure(f"place: {gripper.name} still holds {label} after the release")
        seen = await look(wm, wm.get_element(obj), sensors_of(ctx))
        if not self.dropped and not seen:
            await ctx.progress(f"{label} released; no sensor sees it: trusting the release pose")
            return
        height = (extents(wm.get_element(obj).properties.get(Prop.size)) or (0.0, 0.0, 0.0))[2]
        inside = bool(seen) and lies_in(wm, target, seen[0].pose, height)
        if inside and is_surface(wm, target):  # on its top, not in a box standing there
            inside = containing(wm, seen[0].pose, exclude=[obj]) in (None, target)
        if not self.dropped and inside:
            await wm.transact(observation_ops(obj, seen))
            await ctx.progress(f"{label} seen in {wm.get_element(target).label}")
            return
        ops: list[Op] = observation_ops(obj, seen) if seen else []
        where = containing(wm, seen[0].pose, exclude=[obj]) if seen else None
        ops += move_ops(wm, obj, where)
        await wm.transact(ops)
        found = (
            f"it lies in {where}"
            if where
            else ("it was not seen" if not seen else "it lies outside anything known")
        )
        why = (
            f"dropped on the way ({self.dropped})"
            if self.dropped
            else "it did not land in the target"
        )
        raise SkillFailure(f"place failed: {label} {why}; {found}")

    async def on_preempt(self, ctx: SkillContext) -> None:
        await make_safe(ctx)


class PlaceOn(Place):
    """Put the held object down on a surface at the robot's location.

    The surface is tied to where the robot stands by ``contain(location, surface)`` (a
    station contains its shelves in the scenario scenes), not by ``at``: the ontology makes a
    ``Surface`` a ``Location``, and ``at`` needs a physical object as its subject. A surface
    that no location contains (the meal scenario's worktop, only ``at`` its robot's home) is
    therefore not a ``place_on`` target for the planner."""

    description = SkillDescription(
        name="place_on",
        skill_type="place",
        doc="Put the held object down on a free spot of a surface (a shelf, a table) in reach.",
        parameters=[
            OBJECT,
            ParamSpec(name="surface", type=Cls.Surface, doc="where it goes (on its top)"),
            ParamSpec(
                name="location",
                type=Cls.Location,
                doc="where the robot stands: the station that holds the surface",
            ),
            *DEVICES,
            *[p for p in TUNING if p.name != "wall"],
            offline("edge", "float", 0.03, "margin kept from the surface's edges, m"),
        ],
        pre=[
            contains("gripper", "object"),
            at("robot", "location"),
            contains("location", "surface"),
        ],
        hold=[contains("gripper", "object")],
        post=[contains("surface", "object"), contains("gripper", "object", holds=False)],
        duration=4.0,
    )
    target_param = "surface"


def is_surface(wm: WmClient, element: str) -> bool:
    """Whether the element is a Surface (a shelf, a table, a smart platform) and not a
    container: what is put there stands on its top."""
    cls = wm.get_element(element).type
    onto = wm.ontology
    return onto.is_a(cls, Cls.Surface) and not onto.is_a(cls, Cls.Container)


def _occupied(wm: WmClient, container: str, moving: str) -> list[tuple[Vec3, float]]:
    """Positions (world) and footprint radii of what the container (or surface) holds
    already."""
    found = []
    for child in wm.get_children(container, Rel.contain):
        where = world_transform(wm, child.id) if child.id != moving else None
        if where is not None:
            found.append((where.translation, footprint_radius(child.properties.get(Prop.size))))
    return found
