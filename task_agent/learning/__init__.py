"""What the task layer learns while it works: run times and failed steps.

- :class:`DurationBook`: each (agent, skill)'s run time, learned from every successful step
  (over the distance driven for a step with ``start`` and ``goal`` poses), kept in a JSON file
  that survives restarts (atomic replace; see :mod:`task_agent.learning._durations`).
- :class:`StepTimer`: a plan's step estimates from the book and the poses in the world model;
  the partial-order schedule and the allocation between robots use it
  (:func:`task_agent.planning.to_partial_order`).
- :class:`Lessons`: a task's failed steps (:class:`FailedStep`: agent, skill, parameters,
  reason, physical cause); the next plan excludes each of them
  (:func:`task_agent.planning.exclude_steps`), and when nothing is left the task ends with
  :meth:`Lessons.explain`.
- :class:`TaskLearning`: one task's hook (the executor's): follows its events, records run
  times, keeps its lessons, gives estimated vs actual makespan (:class:`Makespans`).

Pure and light: no planner import. The code: ``_durations``, ``_timing``, ``_lessons``,
``_task``.
"""

from ._durations import DurationBook as DurationBook
from ._durations import SkillTime as SkillTime
from ._lessons import NOT_LEARNED as NOT_LEARNED
from ._lessons import FailedRun as FailedRun
from ._lessons import FailedStep as FailedStep
from ._lessons import Lessons as Lessons
from ._lessons import changed_params as changed_params
from ._task import Makespans as Makespans
from ._task import TaskLearning as TaskLearning
from ._timing import StepTimer as StepTimer
from ._timing import positions as positions

__all__ = [
    "NOT_LEARNED",
    "DurationBook",
    "FailedRun",
    "FailedStep",
    "Lessons",
    "Makespans",
    "SkillTime",
    "StepTimer",
    "TaskLearning",
    "changed_params",
    "positions",
]
