"""Wire schema of the skill layer: skill descriptions, conditions, runs, progress.

A skill **description** is what planners and other hosts see: name, parameters, and pre / hold /
post conditions as data. Implementations (``skill_agent.Skill``) stay in the agent.

Key space (prefix ``skimesh/<mesh>``):

- ``agents/<agent>``                       liveliness token
- ``agents/<agent>/skills``                queryable: :class:`SkillsReply`
- ``agents/<agent>/rpc``                   queryable: :data:`AgentRequest` -> :data:`AgentReply`
  (start, stop, pause, resume, a run's status, the runs, a run's kept events, reload)
- ``agents/<agent>/runs/<run>/progress``   publication: :data:`RunEvent` (progress, then one result)
- ``agents/<agent>/events``                publication: :data:`LogEntry` (the agent's event log)

Unions are tagged (``request``, ``reply``, ``cond``, ``event``, ``kind``); messages only gain
fields with defaults; ``schema_version`` says who wrote them.
"""

from ._codec import decode_event as decode_event
from ._codec import decode_log_entry as decode_log_entry
from ._codec import decode_reply as decode_reply
from ._codec import decode_request as decode_request
from ._log import LogEntry as LogEntry
from ._log import ProgressEntry as ProgressEntry
from ._log import RefusedEntry as RefusedEntry
from ._log import ResultEntry as ResultEntry
from ._log import RunStartedEntry as RunStartedEntry
from ._log import WmWriteEntry as WmWriteEntry
from ._runs import AgentReply as AgentReply
from ._runs import AgentRequest as AgentRequest
from ._runs import ErrorReply as ErrorReply
from ._runs import ListRuns as ListRuns
from ._runs import ListSkills as ListSkills
from ._runs import OkReply as OkReply
from ._runs import PauseRun as PauseRun
from ._runs import Progress as Progress
from ._runs import Reload as Reload
from ._runs import ResultReason as ResultReason
from ._runs import ResumeRun as ResumeRun
from ._runs import RunEvent as RunEvent
from ._runs import RunEvents as RunEvents
from ._runs import RunEventsReply as RunEventsReply
from ._runs import RunFinished as RunFinished
from ._runs import RunInfo as RunInfo
from ._runs import RunResult as RunResult
from ._runs import RunsReply as RunsReply
from ._runs import RunStarted as RunStarted
from ._runs import RunState as RunState
from ._runs import RunStatus as RunStatus
from ._runs import SkillsReply as SkillsReply
from ._runs import StartRun as StartRun
from ._runs import StopRun as StopRun
from ._skills import SCHEMA_VERSION as SCHEMA_VERSION
from ._skills import AndCond as AndCond
from ._skills import Condition as Condition
from ._skills import CustomCond as CustomCond
from ._skills import EmptyCond as EmptyCond
from ._skills import HasPropertyCond as HasPropertyCond
from ._skills import IsSpecifiedCond as IsSpecifiedCond
from ._skills import IsTypeCond as IsTypeCond
from ._skills import NotCond as NotCond
from ._skills import OrCond as OrCond
from ._skills import ParamKind as ParamKind
from ._skills import ParamSpec as ParamSpec
from ._skills import ParamState as ParamState
from ._skills import PropertyCond as PropertyCond
from ._skills import RelationCond as RelationCond
from ._skills import SkillDescription as SkillDescription

__all__ = [
    "SCHEMA_VERSION",
    "AgentReply",
    "AgentRequest",
    "AndCond",
    "Condition",
    "CustomCond",
    "EmptyCond",
    "ErrorReply",
    "HasPropertyCond",
    "IsSpecifiedCond",
    "IsTypeCond",
    "ListRuns",
    "ListSkills",
    "LogEntry",
    "NotCond",
    "OkReply",
    "OrCond",
    "ParamKind",
    "ParamSpec",
    "ParamState",
    "PauseRun",
    "Progress",
    "ProgressEntry",
    "PropertyCond",
    "RefusedEntry",
    "RelationCond",
    "Reload",
    "ResultEntry",
    "ResultReason",
    "ResumeRun",
    "RunEvent",
    "RunEvents",
    "RunEventsReply",
    "RunFinished",
    "RunInfo",
    "RunResult",
    "RunStarted",
    "RunStartedEntry",
    "RunState",
    "RunStatus",
    "RunsReply",
    "SkillDescription",
    "SkillsReply",
    "StartRun",
    "StopRun",
    "WmWriteEntry",
    "decode_event",
    "decode_log_entry",
    "decode_reply",
    "decode_request",
]
