"""How a skimesh recording is laid out in the rerun viewer.

:func:`blueprint` is the default layout of ``skimesh demo`` and ``skimesh sim --rerun``::

    +--------------------------------------+-----------------------+
    |                                      | Plan (graph)          |
    |  World: physics, labels, beliefs     +-----------------------+
    |  (camera framed on the robots and    | Progress per robot    |
    |   the work: :func:`frame`)           +-----------------------+
    |                                      | Cameras (--images)    |
    +-------------+-------------------+----+-----------------------+
    | Task events | World-model       | Agents' logs | Robots' steps |
    | (demo log)  | changes           |   (tabs)                     |
    +-------------+-------------------+------------------------------+

The 3-D view shows ``world/**`` (the physics, with a label over each robot and object) and
``belief/**`` (where the world model believes each object is: cyan wireframe ghosts), each
toggled by its entity path in the viewer's blueprint panel. The side panels are hidden and
the ``sim_time`` timeline selected. Send it with the recording
(``rec.send_blueprint(blueprint(...))``) or save it as an ``.rbl`` file that the viewer loads
next to an ``.rrd`` (``rerun run.rrd layout.rbl``; the application ids must match).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, Literal

import rerun as rr
import rerun.blueprint as rrb

from ._framing import Eye

__all__ = ["BELIEF", "TIMELINE", "WORLD", "blueprint", "camera_entity"]

TIMELINE = "sim_time"
WORLD = "world"
"""The physics: the recorder's bodies (``world/<body>``), each label ``world/<body>/label``."""
BELIEF = "belief"
"""The world model's beliefs: ``belief/<label>``, a ghost per object."""
_PLOT_SECONDS = 30.0  # s of progress shown, up to the time cursor
_ROBOT_COLORS = [(31, 119, 180), (255, 127, 14), (44, 160, 44), (214, 39, 40), (148, 103, 189)]


def camera_entity(camera: str) -> str:
    """The entity of a camera's images (the recorder's name for a MuJoCo camera)."""
    return "cameras/" + camera.replace("/", ".")


def _text_log(name: str, contents: Sequence[str], *, paths: bool) -> rrb.TextLogView:
    return rrb.TextLogView(
        origin="/",
        contents=[f"+ {c}" for c in contents],
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


def _world(eye: Eye | None) -> rrb.Spatial3DView:
    controls = None
    if eye is not None:
        controls = rrb.EyeControls3D(
            kind=rrb.Eye3DKind.Orbital,
            position=eye.position,
            look_target=eye.look_target,
            eye_up=(0.0, 0.0, 1.0),
        )
    return rrb.Spatial3DView(
        origin="/",
        contents=[f"+ {WORLD}/**", f"+ {BELIEF}/**"],
        name="World: physics, labels, world-model beliefs",
        eye_controls=controls,
        line_grid=rrb.LineGrid3D(visible=False),
        background=(38, 42, 50, 255),
        # The recorder logs capsules (arm links) without a fill mode: wireframe by default.
        defaults=[rr.Capsules3D.from_fields(fill_mode="solid")],
    )


def _progress(
    robots: Sequence[str], colors: Mapping[str, tuple[int, int, int]] | None
) -> rrb.TimeSeriesView:
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
    return rrb.TimeSeriesView(
        origin="/",
        contents=contents,
        name="Progress of each robot's step" if robots else "Robots' joints",
        # The last half minute up to the time cursor (a window that scrolls with a live run;
        # the whole run is a barcode of steps).
        axis_x=rrb.TimeAxis(
            view_range=rr.TimeRange(
                start=rrb.TimeRangeBoundary.cursor_relative(seconds=-_PLOT_SECONDS),
                end=rrb.TimeRangeBoundary.cursor_relative(seconds=1.0),
            )
        ),
        axis_y=rrb.ScalarAxis(range=(0.0, 1.05), zoom_lock=True) if robots else None,
        plot_legend=rrb.PlotLegend(corner="LeftTop"),
        overrides=overrides or None,
    )


def blueprint(
    *,
    robots: Sequence[str] = (),
    colors: Mapping[str, tuple[int, int, int]] | None = None,
    eye: Eye | None = None,
    cameras: Sequence[str] = (),
    mission: bool = True,
    play_state: Literal["following", "paused", "playing"] = "following",
) -> rrb.Blueprint:
    """The viewer layout of a skimesh recording (see the module doc).

    ``robots``: the robot (and appliance) names of ``robots/<name>/progress``, one line each
    in the progress plot (none: the plot shows ``robots/**``, joints included), coloured as
    ``colors`` says (the robot's arm colour in the 3-D view; else a palette's). ``eye``: the
    3-D camera (none: the viewer fits the whole scene, floor included; :func:`frame` of
    :func:`scene_points` frames the robots and the work). ``cameras``: the MuJoCo cameras
    whose images are recorded (``cameras/<name>``), one tab each. ``mission``: the plan and
    the mission's logs (``skimesh demo``); without, the device events of ``skimesh sim``.
    ``play_state``: ``following`` (the time cursor at the newest data: right for a live run
    and for a screenshot of a recording cut at the moment to show), ``paused`` or
    ``playing``.
    """
    side: list[Any] = []
    if mission:
        side.append(
            rrb.GraphView(origin="task/plan/graph", name="Plan (arrows: must finish first)")
        )
    side.append(_progress(robots, colors))
    if cameras:
        views = [rrb.Spatial2DView(origin=camera_entity(c), name=c) for c in cameras]
        side.append(rrb.Tabs(*views, active_tab=0) if len(views) > 1 else views[0])
    if mission:
        logs: list[Any] = [
            _text_log("Task events", ["task/events", "demo/log"], paths=False),
            _text_log("World-model changes", ["world_model/changes"], paths=False),
            rrb.Tabs(
                _text_log("Agents' logs", ["agents/**"], paths=True),
                _text_log("Robots' steps", ["robots/**"], paths=True),
                active_tab=0,
            ),
        ]
        shares = [2.0, 2.0, 3.0]
    else:
        logs = [_text_log("Device events", ["events/**"], paths=True)]
        shares = [1.0]
    return rrb.Blueprint(
        rrb.Vertical(
            rrb.Horizontal(
                _world(eye),
                rrb.Vertical(*side) if len(side) > 1 else side[0],
                column_shares=[3, 2],
            ),
            rrb.Horizontal(*logs, column_shares=shares),
            row_shares=[7, 3],
        ),
        rrb.TopPanel(state="hidden"),
        rrb.BlueprintPanel(state="hidden"),
        rrb.SelectionPanel(state="hidden"),
        rrb.TimePanel(state="collapsed", timeline=TIMELINE, play_state=play_state),
        auto_views=False,
    )
