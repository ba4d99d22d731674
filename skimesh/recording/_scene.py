"""The scene's part of the default layout: where the camera looks, labels, robot colours.

:func:`scene_layout` reads a MuJoCo world once, before it steps (its arrays only: no mujoco
import here): the camera framing the robots and the work (:func:`frame` of
:func:`scene_points`), a label per robot (on its base) and per object (over it), and each
robot's arm colour. :func:`record_scene` logs the labels into the world's
recording (static, ``world/<body>/label``: they ride on the bodies) and sends the default
layout (:func:`blueprint`) made from them (:func:`send_layout`); ``skimesh demo`` and
``skimesh sim --rerun`` call it once the world is built, ``skimesh monitor`` calls
:func:`send_layout` with the layout of its mirrored world.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import partial
from typing import Any

import numpy as np
import rerun as rr

from mujoco_sim import SimWorld
from scenario import Scenario

from ._blueprint import WORLD, blueprint
from ._framing import Eye, frame, geom_corners, scene_points

__all__ = [
    "Label",
    "SceneLayout",
    "record_scene",
    "scene_cameras",
    "scene_layout",
    "send_layout",
]

_ABOVE = 0.03  # m: a label's gap above the top of what it names
_CAPSULE = 3  # mujoco.mjtGeom.mjGEOM_CAPSULE
_LABEL_COLOR = (235, 235, 235)


@dataclass(frozen=True)
class Label:
    """A label over a body: ``text`` at ``height`` m above the body's origin."""

    body: str
    text: str
    height: float

    @property
    def entity(self) -> str:
        return f"{WORLD}/{self.body.replace('/', '.')}/label"


@dataclass(frozen=True)
class SceneLayout:
    """What :func:`scene_layout` found."""

    eye: Eye
    labels: list[Label] = field(default_factory=list)
    colors: dict[str, tuple[int, int, int]] = field(default_factory=dict)
    """A robot's arm colour (its first capsule's), by robot name."""


def _names(model: Any) -> list[str]:
    return [str(model.body(b).name) for b in range(model.nbody)]


def _subtree_top(model: Any, data: Any, body: int) -> float:
    """Height of the top of ``body`` and everything attached below it, above its origin
    (plus a gap)."""
    parents = np.asarray(model.body_parentid)
    inside = {body}
    for b in range(body + 1, model.nbody):  # MuJoCo numbers a child after its parent
        if int(parents[b]) in inside:
            inside.add(b)
    owners = np.asarray(model.geom_bodyid)
    geoms = [g for g in range(model.ngeom) if int(owners[g]) in inside]
    if not geoms:
        return _ABOVE
    top = float(geom_corners(model, data, geoms)[:, 2].max())
    return top - float(np.asarray(data.xpos)[body, 2]) + _ABOVE


def scene_layout(
    model: Any, data: Any, *, robots: Sequence[str], objects: Sequence[str]
) -> SceneLayout:
    """The camera, labels and robot colours of a world (after ``mj_forward``; in the
    simulation thread). ``robots``: the scenario's robot names (bodies ``<robot>/...``; the
    label sits on ``<robot>/base``'s origin, else its first body's, where no object's label
    is); ``objects``: the bodies to label by their own name, just over their top (parts,
    containers, appliances; unknown names are skipped)."""
    names = _names(model)
    index = {n: b for b, n in enumerate(names)}
    labels: list[Label] = []
    colors: dict[str, tuple[int, int, int]] = {}
    geom_type, owners = np.asarray(model.geom_type), np.asarray(model.geom_bodyid)
    for robot in robots:
        own = [b for b, n in enumerate(names) if n.startswith(f"{robot}/")]
        base = index.get(f"{robot}/base", own[0] if own else None)
        if base is not None:
            labels.append(Label(names[base], robot, 0.0))
        capsules = [g for g in range(model.ngeom) if geom_type[g] == _CAPSULE and owners[g] in own]
        if capsules:
            r, g, b = (np.clip(model.geom_rgba[capsules[0], :3], 0, 1) * 255).astype(int)
            colors[robot] = (int(r), int(g), int(b))
    for name in objects:
        if name in index:
            labels.append(Label(name, name, _subtree_top(model, data, index[name])))
    eye = frame(scene_points(model, data, robots=robots))
    return SceneLayout(eye=eye, labels=labels, colors=colors)


def scene_cameras(scenario: Scenario) -> list[str]:
    """The scenario's cameras, as the recorder names their images (``<mount>/<site>`` or the
    camera's label)."""
    return [
        f"{c.mount}/{c.site}" if c.mount else c.label
        for c in scenario.sensors
        if c.kind == "camera"
    ]


def send_layout(
    rec: rr.RecordingStream,
    layout: SceneLayout,
    *,
    robots: Sequence[str] = (),
    cameras: Sequence[str] = (),
    mission: bool = True,
) -> None:
    """Log ``layout``'s labels into ``rec`` (static, riding on their bodies) and send the
    default layout framed on it (``robots``: the names of the progress lines, ``cameras``:
    the image views; see :func:`blueprint`)."""
    rec.log("/", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)  # the 3-D view's origin
    for label in layout.labels:
        rec.log(
            label.entity,
            rr.Points3D(
                [[0.0, 0.0, label.height]],
                radii=[0.004],
                colors=[_LABEL_COLOR],
                labels=[label.text],
                show_labels=True,
            ),
            static=True,
        )
    rec.send_blueprint(
        blueprint(
            robots=robots, colors=layout.colors, eye=layout.eye, cameras=cameras, mission=mission
        )
    )


async def record_scene(
    rec: rr.RecordingStream,
    world: SimWorld,
    *,
    robots: Sequence[str] = (),
    mission: bool = True,
    images: bool = False,
) -> SceneLayout:
    """Log the labels of ``world`` into ``rec`` and send the default layout framed on it
    (``robots``: the names of the progress lines, see :func:`blueprint`; ``images``: with
    the cameras' views). Call it once the world is built, before it steps."""
    scenario = world.scenario
    layout = await world.call(
        partial(
            scene_layout,
            robots=[r.name for r in scenario.robots],
            objects=list(world.facts.objects),
        )
    )
    cameras = scene_cameras(scenario) if images else ()
    send_layout(rec, layout, robots=robots, cameras=cameras, mission=mission)
    return layout
