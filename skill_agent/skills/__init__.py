"""The standard skill library: navigate, locate, pick / take_out, place / place_on / serve /
put_in, door skills for an arm and for a smart appliance, drawer skills for an arm, heat,
operate (an appliance's buttons).

Each skill is a :class:`~skill_agent.skill.Skill` subclass with a full description (parameters
typed by ontology classes, pre / hold / post conditions in the SkiROS style), sensing in
``pre_sense`` / ``post_sense`` and honest failures (:class:`~skill_agent.errors.SkillFailure`
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
``serve``          serve: :class:`Serve`, put_in: :class:`PutIn`    arm robots
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

from .appliance import HEATED as HEATED
from .appliance import ApplianceCloseDoor as ApplianceCloseDoor
from .appliance import ApplianceOpenDoor as ApplianceOpenDoor
from .appliance import Heat as Heat
from .doors import ArmCloseDoor as ArmCloseDoor
from .doors import ArmOpenDoor as ArmOpenDoor
from .drawers import ArmCloseDrawer as ArmCloseDrawer
from .drawers import ArmOpenDrawer as ArmOpenDrawer
from .locate import Locate as Locate
from .locate import locate_object as locate_object
from .navigate import Navigate as Navigate
from .operate import Operate as Operate
from .operate import OperateStop as OperateStop
from .pick import Pick as Pick
from .pick import TakeOut as TakeOut
from .place import Place as Place
from .place import PlaceOn as PlaceOn
from .serve import PutIn as PutIn
from .serve import Serve as Serve

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
    "PlaceOn",
    "PutIn",
    "Serve",
    "TakeOut",
    "locate_object",
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
}
"""Conditions (as :func:`skill_agent.conditions.describe` writes them) the planner cannot see:
room left in a container needs counting. Checked when the skill starts."""
