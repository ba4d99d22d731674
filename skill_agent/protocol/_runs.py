"""Runs on the wire: progress and results, run status, the requests an agent answers on
``agents/<agent>/rpc`` and ``agents/<agent>/skills`` and its replies.
"""

from __future__ import annotations

from typing import Literal, TypeAlias

import msgspec
from msgspec import Struct

import meshlink.rpc
from skill_agent.protocol._skills import SCHEMA_VERSION, ParamState, SkillDescription
from wm_store.protocol import Value

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
    param_states: dict[str, ParamState] = msgspec.field(default_factory=dict)
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


class RunEvents(Struct, tag=True, tag_field="request", frozen=True, kw_only=True):
    """One run's state and the events the agent kept of it with ``seq > after_seq``
    (:class:`RunEventsReply`): a run's history, for a client that comes after its start."""

    run_id: str
    after_seq: int = 0


class Reload(Struct, tag=True, tag_field="request", frozen=True, kw_only=True):
    """Re-import the skill plug-ins; running runs finish with the code they started with."""


AgentRequest: TypeAlias = (
    ListSkills
    | StartRun
    | StopRun
    | PauseRun
    | ResumeRun
    | RunStatus
    | ListRuns
    | Reload
    | RunEvents
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


class RunEventsReply(Struct, tag=True, tag_field="reply", frozen=True, kw_only=True):
    """A run's state and its kept events, oldest first, the result last once it ended.
    ``dropped``: progress events the agent did not keep (its bound per run)."""

    run: RunInfo
    events: list[RunEvent]
    dropped: int = 0
    schema_version: int = SCHEMA_VERSION


class ErrorReply(meshlink.rpc.ErrorReply, tag="ErrorReply", frozen=True, kw_only=True):
    """Refused; ``code`` is the error class's code (see ``skill_agent``) or a standard code of
    :mod:`meshlink.rpc` (``bad_request``, ``too_large``, ``internal``). The layer's
    ``ErrorReply`` with the same tag, plus the parameters' states."""

    param_states: dict[str, ParamState] = msgspec.field(default_factory=dict)
    """A start refused because parameters could not all be specified (codes
    ``unspecified_parameter``, ``inference``): every parameter's state at the refusal."""


AgentReply: TypeAlias = (
    SkillsReply | RunStarted | RunFinished | RunsReply | OkReply | RunEventsReply | ErrorReply
)
