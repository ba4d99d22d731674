"""The mission in rerun: what ``skimesh demo`` records beside the 3-D scene, and how it is shown.

- :class:`MissionRecording` logs task events, the plan, each robot's active skill and progress
  and every world-model change into the world's recording stream (:class:`CallText`,
  :func:`step_text`: the lines it writes; :func:`wm_store.describe_change` words the
  world-model changes);
- :func:`record_agent_events` follows the skill agents' event logs into it
  (:class:`AgentEventLines`, :func:`entry_line`, :func:`describe_ops`);
- :func:`blueprint` is the viewer's layout; :func:`inspect_recording`, :func:`frame`,
  :func:`cut_recording` and :func:`scene_points` read a finished ``.rrd`` and aim the camera
  (:class:`RecordingFacts`, :class:`Eye`) for ``scripts/screenshot``, whose helper is
  ``python -m skimesh.recording`` (``--help``).

Importing this package imports rerun: the command line imports it only when it records.
"""

from ._agents import AgentEventLines as AgentEventLines
from ._agents import describe_ops as describe_ops
from ._agents import entry_line as entry_line
from ._agents import record_agent_events as record_agent_events
from ._blueprint import Eye as Eye
from ._blueprint import blueprint as blueprint
from ._blueprint import frame as frame
from ._blueprint import scene_points as scene_points
from ._inspect import RecordingFacts as RecordingFacts
from ._inspect import cut_recording as cut_recording
from ._inspect import inspect_recording as inspect_recording
from ._mission import CallText as CallText
from ._mission import MissionRecording as MissionRecording
from ._mission import step_text as step_text

__all__ = [
    "AgentEventLines",
    "CallText",
    "Eye",
    "MissionRecording",
    "RecordingFacts",
    "blueprint",
    "cut_recording",
    "describe_ops",
    "entry_line",
    "frame",
    "inspect_recording",
    "record_agent_events",
    "scene_points",
    "step_text",
]
