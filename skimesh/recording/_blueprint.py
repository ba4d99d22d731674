"""How a skimesh recording is laid out in the rerun viewer, and where its camera looks.

:func:`blueprint` is the layout: the 3-D world (large, top left), each robot's progress as a
time series (top right), the task events as a text log (below), the side panels hidden and the
``sim_time`` timeline selected. Send it with the recording (``rec.send_blueprint(blueprint(...))``)
or save it as an ``.rbl`` file that the viewer loads next to an ``.rrd``
(``rerun run.rrd layout.rbl``; the application ids must match). :func:`frame` aims the 3-D
view's camera (:class:`Eye`) at a set of points, e.g. :func:`scene_points` of a MuJoCo world.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import rerun as rr
import rerun.blueprint as rrb

__all__ = ["TIMELINE", "Eye", "Vec", "blueprint", "frame", "scene_points"]

TIMELINE = "sim_time"
_PLOT_SECONDS = 30.0  # s of progress shown, up to the time cursor
_FOV_Y = 55.0  # degrees: the vertical field of view of rerun's 3-D views
_ROBOT_COLORS = [(31, 119, 180), (255, 127, 14), (44, 160, 44), (214, 39, 40), (148, 103, 189)]
_GEOM_PLANE = 0  # mujoco.mjtGeom.mjGEOM_PLANE (the model's arrays are read without mujoco)
Vec = np.ndarray[Any, Any]


@dataclass(frozen=True)
class Eye:
    """Where the 3-D view's camera is and what it looks at (world coordinates, metres)."""

    position: tuple[float, float, float]
    look_target: tuple[float, float, float]


def blueprint(
    *,
    robots: Sequence[str] = (),
    colors: Mapping[str, tuple[int, int, int]] | None = None,
    eye: Eye | None = None,
    play_state: Literal["following", "paused", "playing"] = "following",
) -> rrb.Blueprint:
    """The viewer layout of a skimesh recording.

    ``robots``: the robot (and appliance) names of ``robots/<name>/progress``, one line each
    in the progress plot (none: the plot shows ``robots/**``, joints included), coloured as
    ``colors`` says (the robot's arm colour in the 3-D view; else a palette's). ``eye``: the
    3-D camera (none: the viewer fits the whole scene, floor included). ``play_state``:
    ``following`` (the time cursor at the newest data: right for a live run and for a
    screenshot of a recording cut at the moment to show), ``paused`` or ``playing``.
    """
    controls = None
    if eye is not None:
        controls = rrb.EyeControls3D(
            kind=rrb.Eye3DKind.Orbital,
            position=eye.position,
            look_target=eye.look_target,
            eye_up=(0.0, 0.0, 1.0),
        )
    world = rrb.Spatial3DView(
        origin="world",
        name="World (MuJoCo)",
        eye_controls=controls,
        line_grid=rrb.LineGrid3D(visible=False),
        background=(38, 42, 50, 255),
        # The recorder logs capsules (arm links) without a fill mode: wireframe by default.
        defaults=[rr.Capsules3D.from_fields(fill_mode="solid")],
    )

    def text_log(origin: str, name: str, *, paths: bool) -> rrb.TextLogView:
        return rrb.TextLogView(
            origin=origin,
            name=name,
            columns=rrb.TextLogColumns(
                timeline_columns=[rrb.encodings.TimelineColumn(TIMELINE)],
                text_log_columns=[
                    rrb.encodings.TextLogColumn("loglevel", visible=False),
                    rrb.encodings.TextLogColumn("entitypath", visible=paths),
                    rrb.encodings.TextLogColumn("body"),
                ],
            ),
        )

    # the task's events in front; each agent's event log (agents/<agent>/events) behind them
    events = rrb.Tabs(
        text_log("task/events", "Task events", paths=False),
        text_log("agents", "Agents' event logs", paths=True),
        active_tab=0,
    )
    overrides: dict[Any, Any] = {}  # entity path -> visualizer
    if robots:
        contents: list[str] = []
        palette = [c for c in _ROBOT_COLORS if c not in (colors or {}).values()]
        for i, robot in enumerate(robots):
            path = f"robots/{robot}/progress"
            contents.append(f"+ {path}")
            color = (colors or {}).get(robot) or palette[i % len(palette)]
            # Points, not lines: a line would join the end of one step (1.0) to the start of
            # the next (0.0) across the idle time between them.
            overrides[path] = rr.SeriesPoints(
                names=[robot], colors=[color], marker_sizes=[2.5]
            ).visualizer()
    else:
        contents = ["+ robots/**"]  # a recording without a mission: the robots' joints
    progress = rrb.TimeSeriesView(
        origin="/",
        contents=contents,
        name="Progress of each robot's step" if robots else "Robots",
        # The last half minute up to the time cursor (a window that scrolls with a live run;
        # the whole run is a barcode of steps).
        axis_x=rrb.TimeAxis(
            view_range=rr.TimeRange(
                start=rrb.TimeRangeBoundary.cursor_relative(seconds=-_PLOT_SECONDS),
                end=rrb.TimeRangeBoundary.cursor_relative(seconds=1.0),
            )
        ),
        axis_y=rrb.ScalarAxis(range=(0.0, 1.05), zoom_lock=True),
        plot_legend=rrb.PlotLegend(corner="LeftTop"),
        overrides=overrides or None,
    )
    return rrb.Blueprint(
        rrb.Vertical(
            rrb.Horizontal(world, progress, column_shares=[5, 2]),
            events,
            row_shares=[7, 3],
        ),
        rrb.TopPanel(state="hidden"),
        rrb.BlueprintPanel(state="hidden"),
        rrb.SelectionPanel(state="hidden"),
        rrb.TimePanel(state="collapsed", timeline=TIMELINE, play_state=play_state),
        auto_views=False,
    )


def frame(
    points: Vec,
    *,
    azimuth: float = 225.0,
    elevation: float = 38.0,
    fill: float = 0.9,
    aspect: float = 1.9,
    fov_y: float = _FOV_Y,
) -> Eye:
    """A camera that frames ``points`` (n x 3, world coordinates; e.g.
    :meth:`RecordingFacts.corners` or :func:`scene_points`): looking from ``azimuth`` degrees
    (0: from +x, counter-clockwise seen from above) and ``elevation`` degrees above the
    horizon, the points centred and filling ``fill`` of a view of ``aspect`` (width / height)
    with a vertical field of view of ``fov_y`` degrees."""
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    center = (points.min(axis=0) + points.max(axis=0)) / 2
    az, el = math.radians(azimuth), math.radians(elevation)
    back = np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])
    right = np.cross(-back, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, -back)
    tan_y = math.tan(math.radians(fov_y) / 2) * fill
    tan_x = tan_y * aspect

    def fit(center: Vec) -> tuple[float, float, float]:
        """The distance at which every point is in view, and how far off centre (right,
        up) the points' picture is then, per unit of depth."""
        v = points - center
        # seen from center + distance * back, a point is at depth distance - v.back; it is
        # in view if |v.up| <= depth * tan_y and |v.right| <= depth * tan_x
        along, x, y = v @ back, v @ right, v @ up
        distance = max(0.5, float(np.max(along + np.maximum(abs(y) / tan_y, abs(x) / tan_x))))
        depth = distance - along
        mid_x = float(np.max(x / depth) + np.min(x / depth)) / 2
        mid_y = float(np.max(y / depth) + np.min(y / depth)) / 2
        return distance, mid_x, mid_y

    for _ in range(3):  # centre the picture on the points, then fit them
        distance, mid_x, mid_y = fit(center)
        center = center + distance * (mid_x * right + mid_y * up)
    distance, _, _ = fit(center)
    position = center + distance * back
    return Eye(
        position=(float(position[0]), float(position[1]), float(position[2])),
        look_target=(float(center[0]), float(center[1]), float(center[2])),
    )


def scene_points(model: Any, data: Any) -> Vec:
    """Points around every visible geom of a MuJoCo world but its floor (the corners of each
    geom's bounding cube), for :func:`frame`: ``blueprint(eye=frame(scene_points(m, d)))``
    frames a world when its recording starts. Call it after ``mj_forward``."""
    seen = [
        g
        for g in range(model.ngeom)
        if model.geom_rgba[g, 3] > 0 and model.geom_type[g] != _GEOM_PLANE
    ]
    if not seen:
        return np.zeros((1, 3))
    center = np.asarray(data.geom_xpos)[seen]
    radius = np.asarray(model.geom_rbound)[seen][:, None]
    cube = np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).T.reshape(-1, 3)
    points = (center[:, None, :] + radius[:, None, :] * cube[None, :, :]).reshape(-1, 3)
    points[:, 2] = np.maximum(points[:, 2], 0.0)
    return np.asarray(points, dtype=float)
