"""What the simulation knows about a scenario's objects, and the state snapshots it hands out.

:class:`SceneFacts` is static (built once with the model): body ids and sizes of the objects
sensors can see and grippers can hold. :class:`Snapshot` is one frozen copy of the world's
state taken at the end of a batch in the simulation thread and read on the loop; its arrays
are copies (``MjData`` arrays are live views and must never cross threads). The ground-truth
questions tests and the demo ask (``body_pose``, ``object_in``) are answered from a snapshot.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from typing import Any, Literal

import mujoco
import numpy as np
import numpy.typing as npt
from msgspec import Struct

from device_drivers import DeviceKey, UnknownElementError, WorldPose
from mujoco_sim.models._scene import graspable_labels
from mujoco_sim.motion._math import pose_of
from scenario import Scenario

__all__ = ["DeviceStates", "ObjectInfo", "SceneFacts", "Snapshot", "object_in"]

Floats = npt.NDArray[np.float64]


@dataclass(frozen=True)
class ObjectInfo:
    """An object of the scenario: its body, ontology class and shape facts (m)."""

    label: str
    body: int
    type: str
    kind: Literal["part", "container", "appliance"]
    bottom: float
    """Height of the body origin above the object's bottom (parts: half height; else 0)."""
    half: tuple[float, float, float]
    """Half extents of the outside box, in the body frame."""
    wall: float = 0.0
    free_dof: int = -1
    """First velocity index of its free joint (-1: it has none)."""


@dataclass(frozen=True)
class SceneFacts:
    objects: dict[str, ObjectInfo]
    graspable: tuple[str, ...]
    body_ids: dict[str, int]

    @classmethod
    def build(cls, scenario: Scenario, model: Any) -> SceneFacts:
        objects: dict[str, ObjectInfo] = {}

        def free_dof(label: str) -> int:
            body = model.body(label)
            return int(model.jnt_dofadr[body.jntadr[0]]) if body.jntnum[0] else -1

        for p in scenario.parts:
            r = p.size[0]
            if p.shape == "cuboid":
                half = (p.size[0] / 2, p.size[1] / 2, p.size[2] / 2)
            else:
                half = (r, r, p.height / 2)
            body = model.body(p.label).id
            bottom = p.height / 2
            objects[p.label] = ObjectInfo(
                p.label, body, p.type, "part", bottom, half, 0.0, free_dof(p.label)
            )
        for c in scenario.containers:
            half3 = (c.size[0] / 2, c.size[1] / 2, c.size[2] / 2)
            objects[c.label] = ObjectInfo(
                c.label,
                model.body(c.label).id,
                c.type,
                "container",
                0.0,
                half3,
                c.wall,
                free_dof(c.label),
            )
        for a in scenario.appliances:
            half3 = (a.size[0] / 2, a.size[1] / 2, a.size[2] / 2)
            objects[a.label] = ObjectInfo(
                a.label, model.body(a.label).id, a.type, "appliance", 0.0, half3, a.wall
            )
        body_ids = {model.body(b).name: b for b in range(model.nbody)}
        return cls(objects, tuple(graspable_labels(scenario)), body_ids)

    def body(self, name: str) -> int:
        try:
            return self.body_ids[name]
        except KeyError:
            raise UnknownElementError("body", name, self.body_ids) from None


class DeviceStates(Mapping[DeviceKey, Struct]):
    """The device states of a snapshot. Each was captured by the simulation thread as a state
    or as a function building it from copies taken then
    (:meth:`~mujoco_sim.control.Controller.capture`); a function runs on the first read of
    its device, on the reading thread, and its state is kept. A fast world takes many snapshots
    per simulated second and most are never read, so building every state each time would be
    most of a snapshot's cost (see docs/benchmarks.md, section Simulation)."""

    __slots__ = ("_captured",)

    def __init__(self, captured: dict[DeviceKey, Struct | Callable[[], Struct]]) -> None:
        self._captured = captured

    def __getitem__(self, key: DeviceKey) -> Struct:
        state = self._captured[key]
        if isinstance(state, Struct):
            return state
        built = self._captured[key] = state()
        return built

    def __iter__(self) -> Iterator[DeviceKey]:
        return iter(self._captured)

    def __len__(self) -> int:
        return len(self._captured)


@dataclass(frozen=True)
class Snapshot:
    """The world at simulated time ``time`` (copies; see module doc)."""

    time: float
    states: Mapping[DeviceKey, Struct]
    body_pos: Floats
    body_quat: Floats
    ctrl: Floats
    """Every actuator's set-point."""
    speeds: dict[str, float] = field(default_factory=dict)
    """Linear speed of each free object, m/s."""
    attached: frozenset[str] = frozenset()
    """Objects welded to a gripper now."""

    def pose(self, body: int) -> WorldPose:
        return pose_of(self.body_pos[body], self.body_quat[body])


def object_in(snap: Snapshot, facts: SceneFacts, label: str, container: str) -> bool:
    """Is ``label`` physically in ``container``: its centre within the container's inner
    footprint, between its floor and 5 cm above its rim, at rest (< 1 cm/s) and not attached."""
    obj, box = facts.objects[label], facts.objects[container]
    if label in snap.attached or snap.speeds.get(label, 0.0) > 0.01:
        return False
    rot = np.zeros(9)
    mujoco.mju_quat2Mat(rot, snap.body_quat[box.body])
    local = rot.reshape(3, 3).T @ (snap.body_pos[obj.body] - snap.body_pos[box.body])
    hx, hy, hz = box.half
    inner = box.wall
    return bool(
        abs(local[0]) <= hx - inner
        and abs(local[1]) <= hy - inner
        and 0.0 <= local[2] <= 2 * hz + 0.05
    )
