"""The one-process demo behind ``skimesh demo``: every service on loopback, one mission, verified.

- :func:`demo_stack` starts the router, the world-model store, the MuJoCo world, one skill agent
  per robot and the task agent in one process (:class:`StackOptions`, :class:`Stack`);
- :func:`run_mission` submits the goal, follows its events and verifies it
  (:class:`MissionResult`, :func:`summary_lines`);
- :class:`MissionView` prints the events and keeps the summary's figures;
- :func:`verify_goal` checks every goal fact in the world model and in the physics of its
  world (:func:`task_agent.check_goal_facts`, :func:`goal_holds`);
- :func:`run_demo` is one whole run (:class:`DemoSetup`: what is read before the loop starts),
  returning the exit code.

The command (:mod:`skimesh.commands.demo`) parses the arguments, owns the recorder and handles
the signals; the recording is :mod:`skimesh.recording`. Errors: :class:`skimesh.errors.DemoError`.
"""

from ._check import goal_holds as goal_holds
from ._check import verify_goal as verify_goal
from ._mission import MissionResult as MissionResult
from ._mission import run_mission as run_mission
from ._mission import summary_lines as summary_lines
from ._output import MissionView as MissionView
from ._output import RobotStats as RobotStats
from ._run import EXIT_NOT_REACHED as EXIT_NOT_REACHED
from ._run import EXIT_SETUP as EXIT_SETUP
from ._run import DemoSetup as DemoSetup
from ._run import run_demo as run_demo
from ._stack import Stack as Stack
from ._stack import StackOptions as StackOptions
from ._stack import agent_configs as agent_configs
from ._stack import background as background
from ._stack import demo_stack as demo_stack
from ._stack import free_port as free_port

__all__ = [
    "EXIT_NOT_REACHED",
    "EXIT_SETUP",
    "DemoSetup",
    "MissionResult",
    "MissionView",
    "RobotStats",
    "Stack",
    "StackOptions",
    "agent_configs",
    "background",
    "demo_stack",
    "free_port",
    "goal_holds",
    "run_demo",
    "run_mission",
    "summary_lines",
    "verify_goal",
]
