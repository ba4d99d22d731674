"""The standard skill library: navigate, locate, pick / take_out, place / place_on / serve /
put_in, door skills for an arm and for a smart appliance, drawer skills for an arm, heat,
operate (an appliance's buttons).

Each skill is a :class:`~skill_agent.Skill` subclass with a full description (parameters
typed by ontology classes, pre / hold / post conditions in the SkiROS style), sensing in
``pre_sense`` / ``post_sense`` and honest failures (:class:`~skill_agent.SkillFailure`
when the hardware or the sensors contradict the prediction). Motions go through
:mod:`skill_agent.primitives`.

=================  ===============================================  ===========================
module             skills (name: class)                             used by
=================  ===============================================  ===========================
``navigate``       navigate: :class:`Navigate`                      mobile robots
``locate``         locate: :class:`Locate`                          robots with a sensor
``pick``           pick: :class:`Pick`, take_out: :class:`TakeOut`  arm robots
``place``          place: :class:`Place`, place_on (on a surface):  arm robots
                   :class:`PlaceOn`
``serve``          serve: :class:`Serve`, put_in: :class:`PutIn`,   arm robots
                   place_at (into a box in reach): :class:`PlaceAt`
``doors``          open_door / close_door: :class:`ArmOpenDoor`,    arm robots (unpowered doors)
                   :class:`ArmCloseDoor`
``drawers``        open_drawer / close_drawer:                      arm robots
                   :class:`ArmOpenDrawer`, :class:`ArmCloseDrawer`
``appliance``      open_door / close_door / heat:                   a smart appliance's agent
                   :class:`ApplianceOpenDoor`,
                   :class:`ApplianceCloseDoor`, :class:`Heat`
``operate``        operate / operate_stop (press start / stop):     a smart appliance's agent
                   :class:`Operate`, :class:`OperateStop`
=================  ===============================================  ===========================

Every pre- and post-condition has a symbolic face for the planner except those listed in
:data:`RUNTIME_ONLY` (checked when the skill runs only).
"""

from skill_agent.skills._appliance import HEATED as HEATED
from skill_agent.skills._appliance import ApplianceCloseDoor as ApplianceCloseDoor
from skill_agent.skills._appliance import ApplianceOpenDoor as ApplianceOpenDoor
from skill_agent.skills._appliance import Heat as Heat
from skill_agent.skills._doors import ArmCloseDoor as ArmCloseDoor
from skill_agent.skills._doors import ArmOpenDoor as ArmOpenDoor
from skill_agent.skills._drawers import ArmCloseDrawer as ArmCloseDrawer
from skill_agent.skills._drawers import ArmOpenDrawer as ArmOpenDrawer
from skill_agent.skills._locate import Locate as Locate
from skill_agent.skills._locate import locate_object as locate_object
from skill_agent.skills._navigate import Navigate as Navigate
from skill_agent.skills._operate import Operate as Operate
from skill_agent.skills._operate import OperateStop as OperateStop
from skill_agent.skills._pick import Pick as Pick
from skill_agent.skills._pick import TakeOut as TakeOut
from skill_agent.skills._place import Place as Place
from skill_agent.skills._place import PlaceOn as PlaceOn
from skill_agent.skills._serve import PlaceAt as PlaceAt
from skill_agent.skills._serve import PutIn as PutIn
from skill_agent.skills._serve import Serve as Serve
from skill_agent.skills._spots import robot_capacity as robot_capacity

__all__ = [
    "ALL_SKILLS",
    "HEATED",
    "RUNTIME_ONLY",
    "ApplianceCloseDoor",
    "ApplianceOpenDoor",
    "ArmCloseDoor",
    "ArmCloseDrawer",
    "ArmOpenDoor",
    "ArmOpenDrawer",
    "Heat",
    "Locate",
    "Navigate",
    "Operate",
    "OperateStop",
    "Pick",
    "Place",
    "PlaceAt",
    "PlaceOn",
    "PutIn",
    "Serve",
    "TakeOut",
    "locate_object",
    "robot_capacity",
]

ALL_SKILLS = (
    Navigate,
    Locate,
    Pick,
    TakeOut,
    Place,
    PlaceOn,
    Serve,
    PutIn,
    PlaceAt,
    ArmOpenDoor,
    ArmCloseDoor,
    ArmOpenDrawer,
    ArmCloseDrawer,
    ApplianceOpenDoor,
    ApplianceCloseDoor,
    Heat,
    Operate,
    OperateStop,
)
"""Every skill class of the library."""

RUNTIME_ONLY: dict[str, tuple[str, ...]] = {
    "place": ("not full(container)",),
    "serve": ("not full(tray)",),
    "place_at": ("not full(container)",),
}
"""Conditions (as :func:`skill_agent.conditions.describe` writes them) the planner cannot see:
room left in a container needs counting. Checked when the skill starts."""
