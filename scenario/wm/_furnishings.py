"""What the world-model scene gives furniture, containers and appliances beyond their own pose
and size (see :func:`scenario.wm.scenario_ops`): an appliance door's pose and size, a cabinet
drawer's pose, size, state and handle grasp, a closed box's side grasp, a container's capacity.

Poses are world-frame centres (the spatial reasoner's convention); grasps are tcp poses
relative to the element's centre.
"""

from __future__ import annotations

import math

from scenario._drawer_layout import HANDLE_HALF, drawer_layout
from scenario._placement import WorldPlacement
from scenario._schema import ApplianceEntry, FurnitureEntry
from wm_store import WmError
from wm_store.ontology import Ontology, Prop
from wm_store.protocol import Orientation, Pose, Position, SizeCuboid, Value
from wm_store.reasoners import Transform, quat_from_axes, quat_from_yaw

__all__ = [
    "DOOR_HALF_THICKNESS",
    "SIDE_GRASP_BELOW_TOP",
    "SIDE_GRASP_INSET",
    "SIDE_GRASP_MAX_WIDTH",
    "door_label",
    "door_props",
    "drawer_props",
    "pose_at",
    "side_grasp",
    "template_capacity",
]

DOOR_HALF_THICKNESS = 0.012
"""Half the thickness of an appliance door panel, m (as ``mujoco_sim.models`` builds
it)."""
SIDE_GRASP_INSET = 0.035
"""Closed boxes (things carried whole, e.g. into a microwave) get a side grasp as prior
knowledge: the pads this far in from the face the robot approaches, m."""
SIDE_GRASP_BELOW_TOP = 0.015
"""... and this far below the box's top, m."""
SIDE_GRASP_MAX_WIDTH = 0.077
"""... if the box is at most this wide across the fingers (the default gripper opens 85 mm)."""


def door_label(appliance: str) -> str:
    return f"{appliance}-door"


def pose_at(x: float, y: float, z: float, yaw: float = 0.0) -> Pose:
    """A world pose at (x, y, z) turned by ``yaw`` about z."""
    s, c = math.sin(yaw / 2), math.cos(yaw / 2)
    return Pose(Position(x, y, z), Orientation(0.0, 0.0, s, c))


def door_props(a: ApplianceEntry, p: WorldPlacement) -> dict[str, Value]:
    """Pose (centre of the closed panel; x out of the front, y from the hinge to the free
    edge) and size (thickness, width, height) of an appliance's door."""
    d, h = a.size[0] / 2, a.size[2]
    flip = (1.0, 0.0, 0.0, 0.0) if a.hinge == "right" else (0.0, 0.0, 0.0, 1.0)
    body = Transform((p.x, p.y, p.z), quat_from_yaw(p.yaw))
    centre = body.compose(Transform((d + DOOR_HALF_THICKNESS, 0.0, h / 2), flip))
    size = SizeCuboid(x=2 * DOOR_HALF_THICKNESS, y=a.size[1], z=h)
    return {Prop.pose: centre.to_pose(), Prop.size: size}


def drawer_props(f: FurnitureEntry) -> dict[str, Value]:
    """A cabinet's closed drawer: pose (the box's centre; x out of the cabinet's front), size,
    ``drawerOpen = false``, and the handle as a grasp: tcp pointing down at the bar, fingers
    closing along the drawer's x (so one finger sits between the bar and the panel)."""
    assert f.drawer is not None
    layout = drawer_layout(f, f.drawer)
    cabinet = Transform((f.pose.x, f.pose.y, 0.0), quat_from_yaw(f.pose.yaw))
    centre = cabinet.compose(Transform(layout.centre))
    (hx, hy, hz), (cx, cy, cz) = layout.handle, layout.centre
    q = quat_from_axes((0.0, 1.0, 0.0), (1.0, 0.0, 0.0), (0.0, 0.0, -1.0))
    return {
        Prop.pose: centre.to_pose(),
        Prop.size: SizeCuboid(*layout.size),
        Prop.drawerOpen: False,
        Prop.graspPose: Pose(Position(hx - cx, hy - cy, hz - cz), Orientation(*q)),
        Prop.graspWidth: 2 * HANDLE_HALF[0],
    }


def side_grasp(depth: float, height: float) -> Pose:
    """The tcp relative to a box: approaching along the box's +x from its -x face, fingers
    closing across its y, the pads ``SIDE_GRASP_INSET`` m in from the face and
    ``SIDE_GRASP_BELOW_TOP`` m below its top (so the hand, 6 cm tall, clears the surface the
    box stands on)."""
    inset = min(SIDE_GRASP_INSET, depth / 2)
    up = max(0.0, height / 2 - SIDE_GRASP_BELOW_TOP)
    q = quat_from_axes((0.0, 0.0, -1.0), (0.0, 1.0, 0.0), (1.0, 0.0, 0.0))
    return Pose(Position(-depth / 2 + inset, 0.0, up), Orientation(*q))


def template_capacity(ontology: Ontology, cls: str) -> int | None:
    """The ``capacity`` of the nearest default individual of ``cls`` or a superclass that
    sets one (KitBox: 6), else None."""
    for name in ontology.superclasses(cls) if cls in ontology.classes else ():
        try:
            capacity = ontology.template(name).properties.get(Prop.capacity)
        except WmError:  # no (single) default individual of this class
            continue
        if isinstance(capacity, int) and not isinstance(capacity, bool):
            return capacity
    return None
