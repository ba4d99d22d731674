"""skimesh task layer: discovery, planning, multi-robot execution, verification.

Planning, pure core first::

    errors            the error tree (TaskError)
    goals             goal text / Structs -> checked literals over element ids
    discovery_model   the registered agents, robots, devices and skills, from a WM view
    domain            skills + WM + goal -> PlanningTask (one action per agent and skill)
    reachability      the task's semantics: replay, compression, why a goal is unreachable
    planner           unified-planning (Kairos, Fast Downward): Planner, Plan, PDDL output
    partial_order     the plan as a DAG with a schedule; balancing between robots

Hand-written tasks::

    taskfile          TOML task files (sequence / parallel blocks of skill calls)
    verify            offline verification: data flow, types, resources, pre-conditions

Execution, and the Zenoh-facing parts::

    discovery         live discovery: registrations + liveliness tokens
    execution_state   steps, their graph, data flow, the goal check (pure)
    runners           how a skill runs on an agent: over Zenoh, or in-process cores
    run_writes        each run's world-model writes, from the agents' event logs
    steps             a step graph run on the agents: parallel, agent loss, operator fallback
    executor          one task: plan, run, check the goal, replan; abort
    service           the task agent: requests, registry, events (serve_tasks)
    operator          the operator agent: skills a person answers (semi-autonomy)
    client            TaskClient, OperatorClient

``planner``, ``partial_order`` and everything that plans import unified-planning (with numpy
and scipy, ~1.5 s); the execution and Zenoh modules import the skill layer's client and
server. Their names here are imported on first use, so goal parsing stays quick to import.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from .discovery_model import AgentInfo as AgentInfo
from .discovery_model import agents_from_view as agents_from_view
from .domain import PlanningTask as PlanningTask
from .domain import build_task as build_task
from .errors import DiscoveryError as DiscoveryError
from .errors import DomainError as DomainError
from .errors import GoalParseError as GoalParseError
from .errors import PlannerTimeoutError as PlannerTimeoutError
from .errors import PlanningError as PlanningError
from .errors import TaskError as TaskError
from .errors import UnsolvableError as UnsolvableError
from .errors import VerificationError as VerificationError
from .goals import Goal as Goal
from .goals import GoalLiteral as GoalLiteral
from .goals import PropertyGoal as PropertyGoal
from .goals import RelationGoal as RelationGoal
from .goals import check_goal as check_goal
from .goals import goal_from_conditions as goal_from_conditions
from .goals import parse_goal as parse_goal

if TYPE_CHECKING:
    from .client import FileRefusedError as FileRefusedError
    from .client import OperatorClient as OperatorClient
    from .client import RemoteTaskError as RemoteTaskError
    from .client import TaskClient as TaskClient
    from .client import TaskTransportError as TaskTransportError
    from .discovery import Discovery as Discovery
    from .executor import Executor as Executor
    from .operator import OperatorDesk as OperatorDesk
    from .operator import serve_operator as serve_operator
    from .partial_order import Edge as Edge
    from .partial_order import PartialOrderPlan as PartialOrderPlan
    from .partial_order import ScheduledStep as ScheduledStep
    from .partial_order import to_partial_order as to_partial_order
    from .planner import Engine as Engine
    from .planner import Plan as Plan
    from .planner import Planner as Planner
    from .planner import PlanStats as PlanStats
    from .planner import PlanStep as PlanStep
    from .run_writes import RunWrites as RunWrites
    from .runners import CoreRunner as CoreRunner
    from .runners import SkillRunner as SkillRunner
    from .runners import ZenohRunner as ZenohRunner
    from .service import TaskService as TaskService
    from .service import serve_tasks as serve_tasks
    from .taskfile import load_task_file as load_task_file
    from .taskfile import read_task_file as read_task_file
    from .verify import verify as verify

_LAZY = {
    "Edge": "partial_order",
    "PartialOrderPlan": "partial_order",
    "ScheduledStep": "partial_order",
    "to_partial_order": "partial_order",
    "Engine": "planner",
    "Plan": "planner",
    "PlanStats": "planner",
    "PlanStep": "planner",
    "Planner": "planner",
    "FileRefusedError": "client",
    "OperatorClient": "client",
    "RemoteTaskError": "client",
    "TaskClient": "client",
    "TaskTransportError": "client",
    "Discovery": "discovery",
    "Executor": "executor",
    "OperatorDesk": "operator",
    "serve_operator": "operator",
    "RunWrites": "run_writes",
    "CoreRunner": "runners",
    "SkillRunner": "runners",
    "ZenohRunner": "runners",
    "TaskService": "service",
    "serve_tasks": "service",
    "load_task_file": "taskfile",
    "read_task_file": "taskfile",
    "verify": "verify",
}


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'task_agent' has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{module}", __name__), name)
    globals()[name] = value
    return value


__all__ = [
    "AgentInfo",
    "CoreRunner",
    "Discovery",
    "DiscoveryError",
    "DomainError",
    "Edge",
    "Engine",
    "Executor",
    "FileRefusedError",
    "Goal",
    "GoalLiteral",
    "GoalParseError",
    "OperatorClient",
    "OperatorDesk",
    "PartialOrderPlan",
    "Plan",
    "PlanStats",
    "PlanStep",
    "Planner",
    "PlannerTimeoutError",
    "PlanningError",
    "PlanningTask",
    "PropertyGoal",
    "RelationGoal",
    "RemoteTaskError",
    "RunWrites",
    "ScheduledStep",
    "SkillRunner",
    "TaskClient",
    "TaskError",
    "TaskService",
    "TaskTransportError",
    "UnsolvableError",
    "VerificationError",
    "ZenohRunner",
    "agents_from_view",
    "build_task",
    "check_goal",
    "goal_from_conditions",
    "load_task_file",
    "parse_goal",
    "read_task_file",
    "serve_operator",
    "serve_tasks",
    "to_partial_order",
    "verify",
]
