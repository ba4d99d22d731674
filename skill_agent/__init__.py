"""skimesh skill layer: the skill model, the async skill agent runtime and its Zenoh adapter.

Layers inside the package (pure core first, adapters last)::

    protocol, errors             wire schema (descriptions, requests, run events) and error tree
    skill                        the implementation contract: Skill, SkillContext, WorldView
    conditions, params,          conditions (evaluate / effects / planner atoms), parameter
    param_states, inference      specification, states and inference, load-time checks
    run, run_wm, resources,      one run's lifecycle, its recorded world-model view, device
    events, simulated,           locks, the event log, simulated outcomes, composite skills,
    composite, core              AgentCore
    config, plugins              agent config (TOML), skill plug-ins (entry points, paths, reload)
    server, client, adapter      Zenoh: serve an agent, call one, drive external services
    event_feed                   Zenoh: read agents' event logs (``agents/*/events``)

Write a skill: docs/guides/write-a-skill.md.
"""

from .adapter import ExternalServiceSkill as ExternalServiceSkill
from .adapter import external_skill as external_skill
from .client import AgentClient as AgentClient
from .client import find_skills as find_skills
from .client import list_agents as list_agents
from .composite import CompositeSkill as CompositeSkill
from .composite import Parallel as Parallel
from .composite import Retry as Retry
from .composite import Selector as Selector
from .composite import Sequence as Sequence
from .composite import Step as Step
from .conditions import Atom as Atom
from .conditions import ConditionRegistry as ConditionRegistry
from .conditions import CustomCondition as CustomCondition
from .conditions import Verdict as Verdict
from .conditions import effects as effects
from .conditions import evaluate as evaluate
from .conditions import evaluate_all as evaluate_all
from .conditions import parameters_of as parameters_of
from .conditions import symbolic as symbolic
from .config import AgentConfig as AgentConfig
from .config import load_config as load_config
from .core import AgentCore as AgentCore
from .core import SkillEntry as SkillEntry
from .errors import AgentTransportError as AgentTransportError
from .errors import InferenceError as InferenceError
from .errors import ParameterError as ParameterError
from .errors import ParameterTypeError as ParameterTypeError
from .errors import PreconditionError as PreconditionError
from .errors import RemoteSkillError as RemoteSkillError
from .errors import ResourceBusyError as ResourceBusyError
from .errors import RunStateError as RunStateError
from .errors import SkillError as SkillError
from .errors import SkillFailure as SkillFailure
from .errors import SkillLoadError as SkillLoadError
from .errors import UnknownParameterError as UnknownParameterError
from .errors import UnknownRunError as UnknownRunError
from .errors import UnknownSkillError as UnknownSkillError
from .errors import UnspecifiedParameterError as UnspecifiedParameterError
from .event_feed import EventFeed as EventFeed
from .events import EventLog as EventLog
from .params import Specified as Specified
from .params import check_description as check_description
from .params import specify as specify
from .plugins import ENTRY_POINT_GROUP as ENTRY_POINT_GROUP
from .plugins import SkillRegistry as SkillRegistry
from .protocol import AgentReply as AgentReply
from .protocol import AgentRequest as AgentRequest
from .protocol import AndCond as AndCond
from .protocol import Condition as Condition
from .protocol import CustomCond as CustomCond
from .protocol import EmptyCond as EmptyCond
from .protocol import ErrorReply as ErrorReply
from .protocol import HasPropertyCond as HasPropertyCond
from .protocol import IsSpecifiedCond as IsSpecifiedCond
from .protocol import IsTypeCond as IsTypeCond
from .protocol import ListRuns as ListRuns
from .protocol import ListSkills as ListSkills
from .protocol import LogEntry as LogEntry
from .protocol import NotCond as NotCond
from .protocol import OkReply as OkReply
from .protocol import OrCond as OrCond
from .protocol import ParamSpec as ParamSpec
from .protocol import PauseRun as PauseRun
from .protocol import Progress as Progress
from .protocol import PropertyCond as PropertyCond
from .protocol import RelationCond as RelationCond
from .protocol import Reload as Reload
from .protocol import ResumeRun as ResumeRun
from .protocol import RunEvent as RunEvent
from .protocol import RunInfo as RunInfo
from .protocol import RunResult as RunResult
from .protocol import RunsReply as RunsReply
from .protocol import RunStarted as RunStarted
from .protocol import RunStatus as RunStatus
from .protocol import SkillDescription as SkillDescription
from .protocol import SkillsReply as SkillsReply
from .protocol import StartRun as StartRun
from .protocol import StopRun as StopRun
from .resources import ResourceLocks as ResourceLocks
from .run import RunContext as RunContext
from .server import AgentService as AgentService
from .server import run_agent as run_agent
from .server import serve_agent as serve_agent
from .simulated import SimulatedOutcomes as SimulatedOutcomes
from .skill import Skill as Skill
from .skill import SkillContext as SkillContext
from .skill import WorldView as WorldView

__all__ = [
    "ENTRY_POINT_GROUP",
    "AgentClient",
    "AgentConfig",
    "AgentCore",
    "AgentReply",
    "AgentRequest",
    "AgentService",
    "AgentTransportError",
    "AndCond",
    "Atom",
    "CompositeSkill",
    "Condition",
    "ConditionRegistry",
    "CustomCond",
    "CustomCondition",
    "EmptyCond",
    "ErrorReply",
    "EventFeed",
    "EventLog",
    "ExternalServiceSkill",
    "HasPropertyCond",
    "InferenceError",
    "IsSpecifiedCond",
    "IsTypeCond",
    "ListRuns",
    "ListSkills",
    "LogEntry",
    "NotCond",
    "OkReply",
    "OrCond",
    "Parallel",
    "ParamSpec",
    "ParameterError",
    "ParameterTypeError",
    "PauseRun",
    "PreconditionError",
    "Progress",
    "PropertyCond",
    "RelationCond",
    "Reload",
    "RemoteSkillError",
    "ResourceBusyError",
    "ResourceLocks",
    "ResumeRun",
    "Retry",
    "RunContext",
    "RunEvent",
    "RunInfo",
    "RunResult",
    "RunStarted",
    "RunStateError",
    "RunStatus",
    "RunsReply",
    "Selector",
    "Sequence",
    "SimulatedOutcomes",
    "Skill",
    "SkillContext",
    "SkillDescription",
    "SkillEntry",
    "SkillError",
    "SkillFailure",
    "SkillLoadError",
    "SkillRegistry",
    "SkillsReply",
    "Specified",
    "StartRun",
    "Step",
    "StopRun",
    "UnknownParameterError",
    "UnknownRunError",
    "UnknownSkillError",
    "UnspecifiedParameterError",
    "Verdict",
    "WorldView",
    "check_description",
    "effects",
    "evaluate",
    "evaluate_all",
    "external_skill",
    "find_skills",
    "list_agents",
    "load_config",
    "parameters_of",
    "run_agent",
    "serve_agent",
    "specify",
    "symbolic",
]
