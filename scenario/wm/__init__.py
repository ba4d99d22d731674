"""A scenario's initial scene in the world model.

:func:`scenario_ops` turns a :class:`~scenario.Scenario` into the ops of one transaction;
:func:`scene_ops` is what a store or a client writes to load it once (reusing elements that
agents registered first), after the scenario's own ontology terms (:func:`scenario_terms`);
:func:`scene_loaded` tells whether the scene is there already.
"""

from __future__ import annotations

from ._furnishings import DOOR_HALF_THICKNESS as DOOR_HALF_THICKNESS
from ._furnishings import SIDE_GRASP_BELOW_TOP as SIDE_GRASP_BELOW_TOP
from ._furnishings import SIDE_GRASP_INSET as SIDE_GRASP_INSET
from ._furnishings import SIDE_GRASP_MAX_WIDTH as SIDE_GRASP_MAX_WIDTH
from ._furnishings import door_label as door_label
from ._furnishings import template_capacity as template_capacity
from ._ops import scenario_ops as scenario_ops
from ._robots import HOME_6 as HOME_6
from ._robots import HOME_7 as HOME_7
from ._robots import REACH_FRACTION as REACH_FRACTION
from ._robots import device_label as device_label
from ._robots import home_label as home_label
from ._scene import scenario_terms as scenario_terms
from ._scene import scene_loaded as scene_loaded
from ._scene import scene_ops as scene_ops

__all__ = [
    "DOOR_HALF_THICKNESS",
    "HOME_6",
    "HOME_7",
    "REACH_FRACTION",
    "SIDE_GRASP_BELOW_TOP",
    "SIDE_GRASP_INSET",
    "SIDE_GRASP_MAX_WIDTH",
    "device_label",
    "door_label",
    "home_label",
    "scenario_ops",
    "scenario_terms",
    "scene_loaded",
    "scene_ops",
    "template_capacity",
]
