"""Execution: one task run on the agents, from its steps to its final event.

- :class:`Executor` runs one task from start to finish: a goal is planned, its steps run, the
  goal is checked and, after a failed step or a lost agent, planned again from the world model
  as it is now; a hand-written task file runs as written. :meth:`Executor.abort` stops every
  run of the task.
- :class:`StepScheduler` runs a graph of steps on the agents: a step starts as soon as its
  predecessors succeeded, steps on different robots in parallel; agent loss, the failed branch
  stopped, operator fallback (semi-autonomy); ``give_way`` stops it at a step boundary.
- A task's claims (``_claiming``): what its steps need of the site (robots, objects), held
  in the service's :class:`~task_agent.claims.ClaimBook` before they run; a task preempted by
  one of higher priority gives its claim back at a step boundary, waits and plans again.
- :class:`SkillRunner` is how one skill runs on one agent: :class:`ZenohRunner` over the mesh,
  :class:`CoreRunner` on in-process agent cores (tests, benchmarks).
- :class:`EventHistory` keeps a task's events for late watchers (bounded); the task-level
  pause (``Executor.pause`` / ``resume``) is the scheduler's hold (``_hold``).
- :class:`RunWrites` follows the agents' event logs: the world-model revisions each run wrote.
- :class:`SafeStatePhase`: when a task ends unfinished, its robots put down what they hold
  (:func:`held_by`: what an agent's devices hold, from the world model).
- The steps as data (pure): :class:`StepSpec`, :class:`StepGraph`, :func:`steps_from_plan`,
  :func:`steps_from_file`, :func:`resolve_params` (data flow) and :func:`unmet_goal`.

The code: ``_state`` (the steps as data), ``_runners``, ``_run_writes``, ``_history``,
``_hold`` (the pause), ``_steps`` (the scheduler), ``_safe_state``, ``_claiming`` and
``_executor``. The
executor plans through :mod:`task_agent.planning`, so this sub-package imports unified-planning.
"""

from ._executor import EXCLUDED_REASONS as EXCLUDED_REASONS
from ._executor import Executor as Executor
from ._executor import GoalVerifier as GoalVerifier
from ._history import MAX_TASK_EVENTS as MAX_TASK_EVENTS
from ._history import EventHistory as EventHistory
from ._run_writes import RunWrites as RunWrites
from ._run_writes import WatchedRun as WatchedRun
from ._runners import CoreRunner as CoreRunner
from ._runners import OnEvent as OnEvent
from ._runners import OnStarted as OnStarted
from ._runners import SkillRunner as SkillRunner
from ._runners import ZenohRunner as ZenohRunner
from ._safe_state import SafeStatePhase as SafeStatePhase
from ._safe_state import held_by as held_by
from ._state import OPERATOR_NOTE as OPERATOR_NOTE
from ._state import StepGraph as StepGraph
from ._state import StepSpec as StepSpec
from ._state import StepStatus as StepStatus
from ._state import WorldModel as WorldModel
from ._state import resolve_params as resolve_params
from ._state import schedule as schedule
from ._state import steps_from_file as steps_from_file
from ._state import steps_from_plan as steps_from_plan
from ._state import unmet_goal as unmet_goal
from ._steps import EventSink as EventSink
from ._steps import StepOutcome as StepOutcome
from ._steps import StepScheduler as StepScheduler
from ._task_planning import PlanSource as PlanSource

__all__ = [
    "EXCLUDED_REASONS",
    "MAX_TASK_EVENTS",
    "OPERATOR_NOTE",
    "CoreRunner",
    "EventHistory",
    "EventSink",
    "Executor",
    "GoalVerifier",
    "OnEvent",
    "OnStarted",
    "PlanSource",
    "RunWrites",
    "SafeStatePhase",
    "SkillRunner",
    "StepGraph",
    "StepOutcome",
    "StepScheduler",
    "StepSpec",
    "StepStatus",
    "WatchedRun",
    "WorldModel",
    "ZenohRunner",
    "held_by",
    "resolve_params",
    "schedule",
    "steps_from_file",
    "steps_from_plan",
    "unmet_goal",
]
