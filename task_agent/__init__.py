"""skimesh task layer: discovery, planning, multi-robot execution, verification.

Planning, pure core first::

    errors            the error tree (TaskError)
    goals             goal text / Structs -> checked literals over element ids
    discovery_model   the registered agents, robots, devices and skills, from a WM view
    domain            skills + WM + goal -> PlanningTask (one action per agent and skill)
    reachability      the task's semantics: replay, compression, why a goal is unreachable
    planner           unified-planning (Kairos, Fast Downward): Planner, Plan, PDDL output
    partial_order     the plan as a DAG with a schedule; balancing between robots

``planner`` and ``partial_order`` import unified-planning (with numpy and scipy, ~1.5 s): their
names here are imported on first use, so goal parsing and discovery stay quick to import.
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
    from .partial_order import Edge as Edge
    from .partial_order import PartialOrderPlan as PartialOrderPlan
    from .partial_order import ScheduledStep as ScheduledStep
    from .partial_order import to_partial_order as to_partial_order
    from .planner import Engine as Engine
    from .planner import Plan as Plan
    from .planner import Planner as Planner
    from .planner import PlanStats as PlanStats
    from .planner import PlanStep as PlanStep

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
    "DiscoveryError",
    "DomainError",
    "Edge",
    "Engine",
    "Goal",
    "GoalLiteral",
    "GoalParseError",
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
    "ScheduledStep",
    "TaskError",
    "UnsolvableError",
    "VerificationError",
    "agents_from_view",
    "build_task",
    "check_goal",
    "goal_from_conditions",
    "parse_goal",
    "to_partial_order",
]
