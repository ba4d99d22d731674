"""The mission in rerun: what ``skimesh demo`` records beside the 3-D scene, and how it is shown.

- :class:`MissionRecording` logs task events, the plan, each robot's active skill and progress
  and every world-model change into the world's recording stream (:class:`CallText`,
  :func:`step_text`: the lines it writes; :class:`wm_store.ChangeWords` words the
  world-model changes, each against the state before it);
- :class:`MissionFeed` fills it from the mesh: every task's events (the running ones from
  their kept history first) and every agent's event log; ``skimesh demo`` and ``skimesh
  monitor`` both record through it;
- :func:`record_agent_events` follows the skill agents' event logs into it
  (:class:`AgentEventLines`, :func:`entry_line`, :func:`describe_ops`);
- :func:`blueprint` is the viewer's default layout; :func:`record_scene` sends it framed on a
  world (:func:`scene_layout`: :func:`frame` of :func:`scene_points`, :class:`Eye`) with
  labels on its robots and objects (:class:`Label`, :class:`SceneLayout`; :func:`send_layout`
  does it for a layout made elsewhere, :func:`scene_cameras` names the image views);
- :class:`BeliefLayer` draws where the world model believes each object is (ghosts under
  ``belief/``; :meth:`MissionRecording.follow_beliefs`);
- :func:`inspect_recording`, :func:`recorded_eye`, :func:`recorded_views` and
  :func:`cut_recording` read a finished
  ``.rrd`` (:class:`RecordingFacts`) for ``scripts/screenshot``, whose helper is
  ``python -m skimesh.recording`` (``--help``).

Importing this package imports rerun: the command line imports it only when it records.
"""

from ._agents import AgentEventLines as AgentEventLines
from ._agents import describe_ops as describe_ops
from ._agents import entry_line as entry_line
from ._agents import record_agent_events as record_agent_events
from ._belief import BeliefLayer as BeliefLayer
from ._blueprint import blueprint as blueprint
from ._feed import MissionFeed as MissionFeed
from ._framing import Eye as Eye
from ._framing import frame as frame
from ._framing import scene_points as scene_points
from ._inspect import RecordingFacts as RecordingFacts
from ._inspect import cut_recording as cut_recording
from ._inspect import inspect_recording as inspect_recording
from ._mission import CallText as CallText
from ._mission import MissionRecording as MissionRecording
from ._mission import step_text as step_text
from ._recorded import recorded_eye as recorded_eye
from ._recorded import recorded_views as recorded_views
from ._scene import Label as Label
from ._scene import SceneLayout as SceneLayout
from ._scene import record_scene as record_scene
from ._scene import scene_cameras as scene_cameras
from ._scene import scene_layout as scene_layout
from ._scene import send_layout as send_layout

__all__ = [
    "AgentEventLines",
    "BeliefLayer",
    "CallText",
    "Eye",
    "Label",
    "MissionFeed",
    "MissionRecording",
    "RecordingFacts",
    "SceneLayout",
    "blueprint",
    "cut_recording",
    "describe_ops",
    "entry_line",
    "frame",
    "inspect_recording",
    "record_agent_events",
    "record_scene",
    "recorded_eye",
    "recorded_views",
    "scene_cameras",
    "scene_layout",
    "scene_points",
    "send_layout",
    "step_text",
]
