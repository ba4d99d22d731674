"""Wiring a skill agent to its devices: drivers matched to world-model elements by label.

A driver (:mod:`device_drivers`: in-process over a simulated world, or a Zenoh proxy of a
device served elsewhere) knows the world-model *label* of its device (``driver.name``:
``r1-arm``, ``Camera-1``, ``Microwave-1``); skills look drivers up by the *element id* bound to
a hardware parameter. After the agent has registered (its robot and devices are elements,
reused by label when the scenario's scene was loaded first), :func:`bind_devices` maps ids to
drivers and :func:`bind_hardware` turns the configuration's ``[hardware]`` bindings (parameter
-> label) into parameter -> element id::

    drivers = {driver.name: driver for driver in sim_devices(world).values()}
    devices = bind_devices(wm, config.device_labels, drivers, robot=core.robot)
    hardware = bind_hardware(wm, config.hardware, robot=core.robot)

A label resolves to the one element with that label that is not an agent or a skill (an
agent is often named like its robot; the store keeps every other label unique, so there is at
most one), preferring the agent's robot and its ``hasA`` parts should several carry it. The
resolved ``[hardware]`` bindings are what the agent publishes with its skills
(:func:`skill_agent.parameters.with_bindings`), so planners bind the same devices. Pure: reads
the world model's local replica, nothing blocks.

Errors: :class:`WiringError` (a :class:`~skill_agent.SkillLoadError`) when a label of
the configuration names no element or several.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping

from skill_agent._errors import SkillLoadError
from skill_agent._skill import WorldView
from wm_store.protocol import Query
from wm_store.scene import id_sort_key

__all__ = ["WiringError", "bind_devices", "bind_hardware", "element_for_label"]

_NOT_DEVICES = ("Agent", "Skill")


class WiringError(SkillLoadError):
    """A device label of the agent's configuration names no element, or several (its wire
    code stays ``skill_load``)."""


def _parts(view: WorldView, robot: str) -> set[str]:
    found, todo = {robot}, [robot]
    while todo:
        for rel in view.query_relation(todo.pop(), "hasA"):
            if rel.object not in found:
                found.add(rel.object)
                todo.append(rel.object)
    return found


def element_for_label(view: WorldView, label: str, *, robot: str | None = None) -> str:
    """The element id of device ``label`` (see the module doc). Raises WiringError."""
    onto = view.ontology
    candidates = sorted(
        (
            e.id
            for e in view.resolve_element(Query(label=label))
            if not any(c in onto.classes and onto.is_a(e.type, c) for c in _NOT_DEVICES)
        ),
        key=id_sort_key,
    )
    if len(candidates) > 1 and robot is not None:
        mine = _parts(view, robot)
        candidates = [c for c in candidates if c in mine] or candidates
    if len(candidates) == 1:
        return candidates[0]
    what = "no element" if not candidates else f"{len(candidates)} elements ({candidates})"
    raise WiringError(
        f"device label {label!r}: {what} in the world model carry it; load the scenario's "
        "scene first, or fix the label in the agent configuration"
    )


def bind_devices(
    view: WorldView,
    labels: Iterable[str],
    drivers: Mapping[str, object],
    *,
    robot: str | None = None,
) -> dict[str, object]:
    """Element id -> driver for each of ``labels`` that has a driver (``drivers`` by label).
    Labels without a driver are left out (a robot has no driver of its own; devices may be
    served later). Raises WiringError for a label with a driver but no single element."""
    return {
        element_for_label(view, label, robot=robot): drivers[label]
        for label in labels
        if label in drivers
    }


def bind_hardware(
    view: WorldView, bindings: Mapping[str, str], *, robot: str | None = None
) -> dict[str, str]:
    """Hardware parameter -> element id, from parameter -> device label. Raises WiringError."""
    return {param: element_for_label(view, label, robot=robot) for param, label in bindings.items()}
