"""skimesh task layer: discovery, planning, multi-robot execution, verification.

Here: the goals (:func:`parse_goal`, :class:`Goal`), each goal fact checked in the world model
and the physics (:func:`check_goal_facts`), the error tree (:class:`TaskError`) and the client
of the task agent (:class:`TaskClient`, :class:`OperatorClient`). The concepts, each
a sub-package whose ``__init__`` is the public path of its names::

    discovery       the agents, robots, devices and skills: registrations + liveliness
    domain          skills + world model + goal -> PlanningTask (one action per agent and skill)
    reachability    the task's semantics without a planner: replay, compression, diagnosis
    planning        unified-planning (Kairos, Fast Downward): Planner, Plan; the partial order
    verification    offline checks of task files: data flow, types, resources, pre-conditions
    execution       one task run on the agents: Executor, StepScheduler, runners, run writes
    operator        the operator agent: skills a person answers (semi-autonomy)

and three modules::

    protocol        the wire schema: requests, replies, events, task files, operator requests
    taskfile        TOML task files: loading, block ids, the order of calls
    service         the task agent: TaskService, serve_tasks (what ``skimesh task-agent`` runs)

``planning`` imports unified-planning, which is slow to import, and so do ``execution``,
``operator`` and ``service``, which plan or run plans. Importing ``task_agent`` imports the
goals and the errors only; the client is imported on first use.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from ._errors import DiscoveryError as DiscoveryError
from ._errors import DomainError as DomainError
from ._errors import FileRefusedError as FileRefusedError
from ._errors import GoalParseError as GoalParseError
from ._errors import PlannerTimeoutError as PlannerTimeoutError
from ._errors import PlanningError as PlanningError
from ._errors import RemoteTaskError as RemoteTaskError
from ._errors import RequestError as RequestError
from ._errors import StepInputError as StepInputError
from ._errors import TaskError as TaskError
from ._errors import TaskTransportError as TaskTransportError
from ._errors import UnsolvableError as UnsolvableError
from ._errors import VerificationError as VerificationError
from ._goal_text import parse_goal as parse_goal
from ._goals import Goal as Goal
from ._goals import GoalLiteral as GoalLiteral
from ._goals import PropertyGoal as PropertyGoal
from ._goals import RelationGoal as RelationGoal
from ._goals import check_goal as check_goal
from ._goals import goal_from_conditions as goal_from_conditions
from ._goals import literal_atom as literal_atom

if TYPE_CHECKING:
    from ._client import OperatorClient as OperatorClient
    from ._client import TaskClient as TaskClient
    from ._client import new_task_id as new_task_id
    from ._physics import NO_SIMULATOR as NO_SIMULATOR
    from ._physics import check_goal_facts as check_goal_facts

_LAZY = {
    "NO_SIMULATOR": "_physics",
    "check_goal_facts": "_physics",
    "OperatorClient": "_client",
    "TaskClient": "_client",
    "new_task_id": "_client",
}


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'task_agent' has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{module}", __name__), name)
    globals()[name] = value
    return value


__all__ = [
    "NO_SIMULATOR",
    "DiscoveryError",
    "DomainError",
    "FileRefusedError",
    "Goal",
    "GoalLiteral",
    "GoalParseError",
    "OperatorClient",
    "PlannerTimeoutError",
    "PlanningError",
    "PropertyGoal",
    "RelationGoal",
    "RemoteTaskError",
    "RequestError",
    "StepInputError",
    "TaskClient",
    "TaskError",
    "TaskTransportError",
    "UnsolvableError",
    "VerificationError",
    "check_goal",
    "check_goal_facts",
    "goal_from_conditions",
    "literal_atom",
    "new_task_id",
    "parse_goal",
]
