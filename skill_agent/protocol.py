"""Wire schema of the skill layer: skill descriptions, conditions, runs, progress.

A skill **description** is what planners and other hosts see: name, parameters, and pre / hold /
post conditions as data. Implementations (``skill_agent.skill.Skill``) stay in the agent.

Key space (prefix ``skimesh/<mesh>``):

- ``agents/<agent>``                       liveliness token
- ``agents/<agent>/skills``                queryable: :class:`SkillsReply`
- ``agents/<agent>/rpc``                   queryable: :data:`AgentRequest` -> :data:`AgentReply`
- ``agents/<agent>/runs/<run>/progress``   publication: :data:`RunEvent` (progress, then one result)
- ``agents/<agent>/events``                publication: :data:`LogEntry` (the agent's event log)

Unions are tagged (``request``, ``reply``, ``cond``, ``event``, ``kind``); messages only gain
fields with defaults; ``schema_version`` says who wrote them.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal, TypeAlias

import msgspec
from msgspec import Meta, Struct

from wm_store.protocol import Comparator, Op, Query, Value

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
    "encode",
]

SCHEMA_VERSION = 1

# --------------------------------------------------------------------------- parameters

ParamKind = Literal["online", "offline", "hardware"]

ParamState = Literal["initialized", "specified"]
"""A parameter's state (SkiROS): ``initialized`` while it has no value (declared, not given,
no default, not yet inferred), ``specified`` once it has one (given and checked, a default,
inferred, or a device bound). A run starts only when every required parameter is
``specified``; an optional parameter may stay ``initialized`` (its value is None)."""


class ParamSpec(Struct, frozen=True, kw_only=True):
    """One parameter of a skill.

    ``type`` is either an ontology class (an *element parameter*: its value is an element id,
    and any element of that class or a subclass fits) or a value kind (``float``, ``int``,
    ``bool``, ``str``, ``Pose``, ``Position``, ``Orientation``, ``SizeCuboid``, ... , ``list``).
    Kinds: ``online`` = the objects acted on, ``offline`` = configuration with defaults,
    ``hardware`` = devices of the robot (element parameters whose devices the run locks).
    ``partial`` narrows an element parameter further (SkiROS "partial definition"): label,
    property filters, relations (``?`` = the candidate).
    """

    name: str
    type: str
    kind: ParamKind = "online"
    doc: str = ""
    default: Value = None
    optional: bool = False
    partial: Query | None = None


# --------------------------------------------------------------------------- conditions
# Conditions are data: each has a run-time face (evaluated against the world model by
# skill_agent.conditions) and a symbolic face (a predicate for the planner). Parameter
# references are parameter names; a post-condition is also the skill's predicted effect.


class RelationCond(Struct, tag=True, tag_field="cond", frozen=True, kw_only=True):
    """``predicate(subject, object)`` holds (or, with ``holds=False``, does not)."""

    subject: str
    predicate: str
    object: str
    holds: bool = True


class PropertyCond(Struct, tag=True, tag_field="cond", frozen=True, kw_only=True):
    """``param.property <op> value`` (``near`` uses ``tolerance``)."""

    param: str
    property: str
    op: Comparator = "eq"
    value: Value = None
    tolerance: float = 0.0


class HasPropertyCond(Struct, tag=True, tag_field="cond", frozen=True, kw_only=True):
    param: str
    property: str
    holds: bool = True


class IsTypeCond(Struct, tag=True, tag_field="cond", frozen=True, kw_only=True):
    """The element bound to ``param`` is a ``cls`` (or a subclass)."""

    param: str
    cls: str


class EmptyCond(Struct, tag=True, tag_field="cond", frozen=True, kw_only=True):
    """The location/container/gripper ``param`` contains nothing (``holds=False``: something).
    With ``full=True``: it holds as many things as its ``capacity`` property allows."""

    param: str
    predicate: str = "contain"
    holds: bool = True
    full: bool = False


class IsSpecifiedCond(Struct, tag=True, tag_field="cond", frozen=True, kw_only=True):
    param: str


class CustomCond(Struct, tag=True, tag_field="cond", frozen=True, kw_only=True):
    """A condition class registered by name in the agent (``skill_agent.conditions``)."""

    name: str
    params: list[str] = []
    args: dict[str, Value] = {}


class AndCond(Struct, tag=True, tag_field="cond", frozen=True, kw_only=True):
    items: list[Condition]


class OrCond(Struct, tag=True, tag_field="cond", frozen=True, kw_only=True):
    items: list[Condition]


class NotCond(Struct, tag=True, tag_field="cond", frozen=True, kw_only=True):
    item: Condition


Condition: TypeAlias = (
    RelationCond
    | PropertyCond
    | HasPropertyCond
    | IsTypeCond
    | EmptyCond
    | IsSpecifiedCond
    | CustomCond
    | AndCond
    | OrCond
    | NotCond
)


class SkillDescription(Struct, frozen=True, kw_only=True):
    """What a skill does, as planners and other hosts see it."""

    name: str
    skill_type: str = ""
    """The family several implementations share (e.g. ``pick``); defaults to ``name``."""
    version: str = "1.0"
    doc: str = ""
    parameters: list[ParamSpec] = []
    pre: list[Condition] = []
    hold: list[Condition] = []
    """Must stay true while the skill executes; a violation aborts the run."""
    post: list[Condition] = []
    """Checked after ``post_sense``; their effects are committed to the world model."""
    duration: Annotated[float, Meta(ge=0)] = 1.0
    """Estimated seconds, used by the planner to balance robots."""
    timeout: Annotated[float, Meta(gt=0)] | None = None
    sensing_max_age: Annotated[float, Meta(ge=0)] | None = None
    """Skip sensing when the data it refreshes is younger than this (seconds)."""

    @property
    def family(self) -> str:
        return self.skill_type or self.name


# --------------------------------------------------------------------------- runs

RunState = Literal[
    "pending",
    "pre_sense",
    "checking_pre",
    "executing",
    "paused",
    "post_sense",
    "checking_post",
    "committing",
    "succeeded",
    "failed",
    "preempted",
]

ResultReason = Literal[
    "ok",
    "precondition",
    "execution",
    "postcondition",
    "preempted",
    "timeout",
    "hold_violated",
    "error",
]


class Progress(Struct, tag=True, tag_field="event", frozen=True, kw_only=True):
    """A step of a run: state, step name, message, fraction done (0..1, or -1 unknown)."""

    run_id: str
    agent: str
    skill: str
    seq: int
    state: RunState
    step: str = ""
    message: str = ""
    fraction: float = -1.0
    stamp: float = 0.0
    schema_version: int = SCHEMA_VERSION


class RunResult(Struct, tag=True, tag_field="event", frozen=True, kw_only=True):
    """The final event of a run."""

    run_id: str
    agent: str
    skill: str
    seq: int
    success: bool
    reason: ResultReason
    message: str = ""
    params: dict[str, Value] = {}
    started_at: float = 0.0
    finished_at: float = 0.0
    effects_revision: int = 0
    """World-model revision of the committed effects (0 if none)."""
    trusted_wm: list[str] = []
    """Sensing steps skipped because the world-model data was fresh enough."""
    schema_version: int = SCHEMA_VERSION


RunEvent: TypeAlias = Progress | RunResult


class RunInfo(Struct, frozen=True, kw_only=True):
    run_id: str
    skill: str
    state: RunState
    params: dict[str, Value] = {}
    resources: list[str] = []
    started_at: float = 0.0
    result: RunResult | None = None
    param_states: dict[str, ParamState] = {}
    """Every parameter's state in the run: ``specified``, or ``initialized`` for an optional
    one left without a value."""


# --------------------------------------------------------------------------- requests


class ListSkills(Struct, tag=True, tag_field="request", frozen=True, kw_only=True):
    pass


class StartRun(Struct, tag=True, tag_field="request", frozen=True, kw_only=True):
    """Start ``skill`` with ``params`` (element parameters take element ids).

    ``queue``: wait for busy hardware instead of being refused. ``run_id``: chosen by the caller
    (idempotent retries); the agent makes one if empty. ``simulate``: run in simulated-outcome
    mode even if the agent runs real hardware."""

    skill: str
    params: dict[str, Value] = {}
    queue: bool = False
    run_id: str = ""
    timeout: float | None = None
    simulate: bool = False
    author: str = ""
    wait: bool = False
    """Answer with the run's final result (:class:`RunFinished`) instead of
    :class:`RunStarted`: one round trip for a short skill. The request's time-out must cover
    the whole run; progress is still published."""


class StopRun(Struct, tag=True, tag_field="request", frozen=True, kw_only=True):
    run_id: str


class PauseRun(Struct, tag=True, tag_field="request", frozen=True, kw_only=True):
    run_id: str


class ResumeRun(Struct, tag=True, tag_field="request", frozen=True, kw_only=True):
    run_id: str


class RunStatus(Struct, tag=True, tag_field="request", frozen=True, kw_only=True):
    run_id: str


class ListRuns(Struct, tag=True, tag_field="request", frozen=True, kw_only=True):
    active_only: bool = True


class Reload(Struct, tag=True, tag_field="request", frozen=True, kw_only=True):
    """Re-import the skill plug-ins; running runs finish with the code they started with."""


AgentRequest: TypeAlias = (
    ListSkills | StartRun | StopRun | PauseRun | ResumeRun | RunStatus | ListRuns | Reload
)


class SkillsReply(Struct, tag=True, tag_field="reply", frozen=True, kw_only=True):
    agent: str
    skills: list[SkillDescription]
    simulated: bool = False
    schema_version: int = SCHEMA_VERSION


class RunStarted(Struct, tag=True, tag_field="reply", frozen=True, kw_only=True):
    run_id: str
    params: dict[str, Value] = {}
    """Every parameter as specified for the run, inferred ones included."""
    inferred: dict[str, str] = {}
    """Why each inferred parameter got its value."""
    schema_version: int = SCHEMA_VERSION


class RunFinished(Struct, tag=True, tag_field="reply", frozen=True, kw_only=True):
    """The answer to ``StartRun(wait=True)``: the run's final result."""

    result: RunResult
    inferred: dict[str, str] = {}
    schema_version: int = SCHEMA_VERSION


class RunsReply(Struct, tag=True, tag_field="reply", frozen=True, kw_only=True):
    runs: list[RunInfo]
    schema_version: int = SCHEMA_VERSION


class OkReply(Struct, tag=True, tag_field="reply", frozen=True, kw_only=True):
    message: str = ""
    schema_version: int = SCHEMA_VERSION


class ErrorReply(Struct, tag=True, tag_field="reply", frozen=True, kw_only=True):
    """Refused; ``code`` is the error class's code (see ``skill_agent.errors``)."""

    code: str
    message: str
    param_states: dict[str, ParamState] = {}
    """A start refused because parameters could not all be specified (codes
    ``unspecified_parameter``, ``inference``): every parameter's state at the refusal."""
    schema_version: int = SCHEMA_VERSION


AgentReply: TypeAlias = SkillsReply | RunStarted | RunFinished | RunsReply | OkReply | ErrorReply

# --------------------------------------------------------------------------- event log
# One entry per thing the agent's runtime did (``skill_agent.events.EventLog``), published on
# ``agents/<agent>/events`` and appended to the agent's JSON-lines file. Tag field ``kind``;
# not frozen: the log stamps an entry when it records it.


class RunStartedEntry(Struct, tag="run_started", tag_field="kind", kw_only=True):
    """A run was accepted (parameters specified, resources locked or queued); ``parent``: the
    run of a composite skill this one is a sub-run of."""

    agent: str
    run_id: str
    skill: str
    params: dict[str, Value] = {}
    inferred: dict[str, str] = {}
    resources: list[str] = []
    simulated: bool = False
    queued: bool = False
    parent: str = ""
    stamp: float = 0.0
    schema_version: int = SCHEMA_VERSION


class ProgressEntry(Struct, tag="progress", tag_field="kind", kw_only=True):
    progress: Progress
    stamp: float = 0.0
    schema_version: int = SCHEMA_VERSION


class ResultEntry(Struct, tag="result", tag_field="kind", kw_only=True):
    result: RunResult
    stamp: float = 0.0
    schema_version: int = SCHEMA_VERSION


class RefusedEntry(Struct, tag="refused", tag_field="kind", kw_only=True):
    """A start request refused before any run existed (or at its pre-condition check)."""

    agent: str
    skill: str
    code: str
    message: str
    run_id: str = ""
    stamp: float = 0.0
    schema_version: int = SCHEMA_VERSION


class WmWriteEntry(Struct, tag="wm_write", tag_field="kind", kw_only=True):
    """A world-model transaction committed for a run: its effects, or a write of its skill
    (through ``ctx.wm``'s write methods or ``ctx.transact``, in any skill method)."""

    agent: str
    run_id: str
    revision: int
    ops: list[Op]
    step: str = ""
    """The run's step when it wrote: ``pre_sense``, ``execute``, ``post_sense``, ``commit``
    (the effects), ``preempt`` (``on_preempt``); "" from an older agent."""
    stamp: float = 0.0
    schema_version: int = SCHEMA_VERSION


LogEntry: TypeAlias = RunStartedEntry | ProgressEntry | ResultEntry | RefusedEntry | WmWriteEntry

# --------------------------------------------------------------------------- codecs

_encoder = msgspec.msgpack.Encoder()
_request_decoder = msgspec.msgpack.Decoder(AgentRequest)
_reply_decoder = msgspec.msgpack.Decoder(AgentReply)
_event_decoder = msgspec.msgpack.Decoder(RunEvent)
_entry_decoder = msgspec.msgpack.Decoder(LogEntry)


def encode(message: Any) -> bytes:
    return _encoder.encode(message)


def decode_request(data: bytes) -> AgentRequest:
    return _request_decoder.decode(data)  # type: ignore[no-any-return]  # union decoder is untyped


def decode_reply(data: bytes) -> AgentReply:
    return _reply_decoder.decode(data)  # type: ignore[no-any-return]  # union decoder is untyped


def decode_event(data: bytes) -> RunEvent:
    return _event_decoder.decode(data)  # type: ignore[no-any-return]  # union decoder is untyped


def decode_log_entry(data: bytes) -> LogEntry:
    return _entry_decoder.decode(data)  # type: ignore[no-any-return]  # union decoder is untyped
