"""The default layout of a recording: the camera framed on the scene (computed from where the
robots, stations and objects are, not a constant), labels over robots and objects, the views
of the blueprint, and the layout's camera read back from a recording."""

from __future__ import annotations

import math
from pathlib import Path

import mujoco
import numpy as np
import pytest
import rerun as rr
import rerun.chunk

from skimesh.recording import (
    Eye,
    blueprint,
    frame,
    recorded_eye,
    recorded_views,
    scene_layout,
    scene_points,
)

FOV_Y = 55.0

# A made-up site: two robots at home, two stations with a shelf each, parts on a table; on a
# 10 m floor that the camera must not frame.
SCENE = """
<mujoco>
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1"/>
    <body name="r1/base_x"><joint type="slide" axis="1 0 0"/>
      <body name="r1/base" pos="-1 -1 0.1">
        <geom type="box" size="0.25 0.2 0.1" rgba="0.3 0.3 0.3 1"/>
        <body name="r1/arm" pos="0 0 0.1">
          <geom type="capsule" fromto="0 0 0 0 0 0.6" size="0.04" rgba="0.2 0.4 0.8 1"/>
        </body>
      </body>
    </body>
    <body name="r2/base" pos="-1 1 0.1"><joint type="free"/>
      <geom type="box" size="0.25 0.2 0.1" rgba="0.3 0.3 0.3 1"/>
    </body>
    <body name="Station-1" pos="1 -1 0.005"><geom type="box" size="0.4 0.4 0.005"/></body>
    <body name="Shelf-1" pos="1.6 -1 0.35"><geom type="box" size="0.3 0.6 0.35"/></body>
    <body name="Gear-1" pos="1.5 -1 0.72"><joint type="free"/>
      <geom type="cylinder" size="0.03 0.0125"/>
    </body>
    <body name="Hidden" pos="4 4 0"><geom type="box" size="0.1 0.1 0.1" rgba="1 1 1 0"/></body>
  </worldbody>
</mujoco>
"""


def in_view(eye: Eye, points: np.ndarray, *, aspect: float) -> np.ndarray:
    """Whether each point is inside the view of a camera at ``eye`` (z up)."""
    pos, target = np.array(eye.position), np.array(eye.look_target)
    forward = (target - pos) / np.linalg.norm(target - pos)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    v = points - pos
    depth = v @ forward
    tan_y = math.tan(math.radians(FOV_Y) / 2)
    inside = (
        (depth > 0)
        & (np.abs(v @ up) <= depth * tan_y + 1e-9)
        & (np.abs(v @ right) <= depth * tan_y * aspect + 1e-9)
    )
    return np.asarray(inside, dtype=bool)


def layout(scale: float = 1.0, shift: tuple[float, float, float] = (0, 0, 0)) -> np.ndarray:
    """Corners of made-up bodies: two robots, two stations, a shelf (metres)."""
    boxes = [
        ((-1.0, -1.0, 0.5), (0.3, 0.3, 0.5)),
        ((-1.0, 1.0, 0.5), (0.3, 0.3, 0.5)),
        ((1.0, -1.0, 0.0), (0.4, 0.4, 0.01)),
        ((1.0, 1.0, 0.0), (0.4, 0.4, 0.01)),
        ((1.6, 1.0, 0.35), (0.3, 0.6, 0.35)),
    ]
    cube = np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).T.reshape(-1, 3)
    points = np.concatenate([np.array(c) + np.array(h) * cube for c, h in boxes])
    return np.asarray(points * scale + np.array(shift), dtype=float)


def test_the_camera_frames_every_point_of_the_layout_and_no_more() -> None:
    points = layout()
    eye = frame(points, aspect=1.9, fill=0.9)
    assert in_view(eye, points, aspect=1.9).all()
    # the points fill the view: at 80 % of the distance some would fall outside it
    pos, target = np.array(eye.position), np.array(eye.look_target)
    near = target + 0.8 * (pos - target)
    closer = Eye((float(near[0]), float(near[1]), float(near[2])), eye.look_target)
    assert not in_view(closer, points, aspect=1.9).all()
    # the camera looks at the layout (the picture centred: the target may sink a little)
    lo, hi = points.min(axis=0), points.max(axis=0)
    assert (lo[:2] <= target[:2]).all() and (target[:2] <= hi[:2]).all()
    # a 10 m floor (what the viewer frames by itself) would put the camera twice as far
    floor = np.array([[x, y, 0.0] for x in (-5, 5) for y in (-5, 5)])
    whole = frame(np.concatenate([points, floor]), aspect=1.9, fill=0.9)
    distance = math.dist(eye.position, eye.look_target)
    assert math.dist(whole.position, whole.look_target) > 2 * distance
    assert not in_view(eye, floor, aspect=1.9).all()


def test_the_camera_follows_the_layout() -> None:
    eye = frame(layout())
    moved = frame(layout(shift=(3.0, -2.0, 0.0)))
    bigger = frame(layout(scale=2.0))
    offset = np.array(moved.look_target) - np.array(eye.look_target)
    assert offset == pytest.approx([3.0, -2.0, 0.0], abs=1e-6)
    assert np.array(moved.position) - np.array(eye.position) == pytest.approx(offset, abs=1e-6)
    distance = math.dist(eye.position, eye.look_target)
    assert math.dist(bigger.position, bigger.look_target) == pytest.approx(2 * distance, rel=1e-6)
    # seen from the default direction: from -x, -y (azimuth 225 degrees), above
    direction = np.array(eye.position) - np.array(eye.look_target)
    assert direction[0] < 0 and direction[1] < 0 and direction[2] > 0


@pytest.fixture
def world() -> tuple[mujoco.MjModel, mujoco.MjData]:
    model = mujoco.MjModel.from_xml_string(SCENE)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    return model, data


def test_scene_points_leave_out_the_floor_and_what_is_not_drawn(
    world: tuple[mujoco.MjModel, mujoco.MjData],
) -> None:
    points = scene_points(*world)
    lo, hi = points.min(axis=0), points.max(axis=0)
    assert lo[2] == 0.0  # nothing below the floor
    assert lo[0] > -2.0 and hi[0] < 2.5 and lo[1] > -2.0 and hi[1] < 2.0  # not the 10 m floor
    assert hi[0] == pytest.approx(1.9)  # the shelf's far side, exactly (its box, not a sphere)
    assert hi[2] == pytest.approx(0.84)  # the top of r1's arm: 0.2 + 0.6 m and its cap
    # of a robot, only its base: its arm raised at the start does not stretch the view
    work = scene_points(*world, robots=["r1", "r2"])
    assert work.max(axis=0)[2] == pytest.approx(0.72 + 0.0125)  # the gear's top, on the shelf
    assert work.min(axis=0)[0] == pytest.approx(-1.25)  # r1's and r2's bases are in


def test_scene_layout_labels_robots_and_objects_and_takes_the_arm_colour(
    world: tuple[mujoco.MjModel, mujoco.MjData],
) -> None:
    model, data = world
    found = scene_layout(
        model, data, robots=["r1", "r2"], objects=["Station-1", "Gear-1", "Nowhere"]
    )
    labels = {label.text: label for label in found.labels}
    assert sorted(labels) == ["Gear-1", "Station-1", "r1", "r2"]  # unknown bodies skipped
    assert labels["r1"].body == "r1/base" and labels["r1"].entity == "world/r1.base/label"
    assert labels["r1"].height == 0.0  # on the base, below the objects it carries
    # just over the top of an object (a 2.5 cm high gear, its origin at its centre)
    assert labels["Gear-1"].height == pytest.approx(0.0125 + 0.03, abs=0.01)
    assert found.colors == {"r1": (51, 102, 204)}  # r2 has no capsule: the palette's
    assert found.eye == frame(scene_points(model, data, robots=["r1", "r2"]))


def _views(path: Path) -> dict[str, tuple[str, str]]:
    return recorded_views(rerun.chunk.RrdReader(str(path)))


def _queries(path: Path) -> str:
    """The content queries of every view of a layout, one per line."""
    reader = rerun.chunk.RrdReader(str(path))
    lines = []
    for store in reader.blueprints():
        for chunk in reader.stream(store=store).to_chunks():
            batch = chunk.to_record_batch()
            if "ViewContents:query" in batch.schema.names:
                for cell in batch.column("ViewContents:query").to_pylist():
                    lines += [str(q) for q in cell or []]
    return "\n".join(lines)


def test_the_default_layout_holds_the_mission_views(tmp_path: Path) -> None:
    eye = Eye((-2.0, -3.0, 2.5), (0.2, 0.1, 0.3))
    layout = blueprint(robots=["r1", "r2"], eye=eye, cameras=["Camera-1", "r1/wrist_camera"])
    path = tmp_path / "layout.rbl"
    layout.save("skimesh-test", path)
    assert _views(path) == {
        "World: physics, labels, world-model beliefs": ("3D", "/"),
        "Plan (arrows: must finish first)": ("Graph", "/task/plan/graph"),
        "Progress of each robot's step": ("TimeSeries", "/"),
        "Camera-1": ("2D", "/cameras/Camera-1"),
        "r1/wrist_camera": ("2D", "/cameras/r1.wrist_camera"),
        "Task events": ("TextLog", "/"),
        "World-model changes": ("TextLog", "/"),
        "Agents' logs": ("TextLog", "/"),
        "Robots' steps": ("TextLog", "/"),
    }
    text = _queries(path)
    for shown in ("world/**", "belief/**", "world_model/changes", "agents/**", "task/events"):
        assert f"+ {shown}" in text or f"+ /{shown}" in text, (shown, text)


def test_a_world_alone_shows_its_device_events_and_no_plan(tmp_path: Path) -> None:
    path = tmp_path / "layout.rbl"
    blueprint(mission=False).save("skimesh-test", path)
    assert set(_views(path)) == {
        "World: physics, labels, world-model beliefs",
        "Robots' joints",
        "Device events",
    }


def test_the_camera_of_the_layout_is_read_back_from_the_recording(tmp_path: Path) -> None:
    path = tmp_path / "run.rrd"
    rec = rr.RecordingStream("skimesh-test")
    rec.set_sinks(rr.FileSink(str(path)))
    rec.log("world/thing", rr.Points3D([[0.0, 0.0, 0.0]]))
    eye = Eye((-2.0, -3.0, 2.5), (0.25, 0.125, 0.5))
    rec.send_blueprint(blueprint(eye=eye))
    rec.flush()
    rec.disconnect()
    assert recorded_eye(rerun.chunk.RrdReader(str(path))) == eye
