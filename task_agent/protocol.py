"""Wire schema of the task layer: task service requests, task events, hand-written task files.

Key space (prefix ``skimesh/<mesh>``):

- ``tasks/rpc``            queryable: one :data:`TaskRequest` -> one :data:`TaskReply`
- ``tasks/<task>/events``  publication: :data:`TaskEvent`, from ``TaskStarted`` to one
  ``TaskFinished``; the events so far are also kept by the task agent (``TaskHistory``), so a
  watcher that comes late fetches them by ``seq`` before following the stream
- ``operator/rpc``         queryable of the operator agent's pending requests (semi-autonomy)

A task is either a **goal** (world-model facts, planned by the task agent) or a **task file**
(hand-written sequence / parallel blocks of skill calls, verified before it runs). Unions are
tagged (``request``, ``reply``, ``event``, ``block``); messages only gain fields with defaults.
"""

from __future__ import annotations

from typing import Annotated, Literal, TypeAlias

from msgspec import Meta, Struct

from meshlink.rpc import Decoder, ErrorReply
from wm_store.protocol import Value

from ._goals import Goal

__all__ = [
    "READ_REQUESTS",
    "SCHEMA_VERSION",
    "AbortTask",
    "AnswerPending",
    "Call",
    "FactCheck",
    "GoalCheck",
    "HistoryReply",
    "ListPending",
    "ListTasks",
    "LostAgent",
    "LostFact",
    "OkReply",
    "OperatorReply",
    "OperatorRequest",
    "Parallel",
    "PartialResult",
    "PauseTask",
    "PendingReply",
    "PendingStep",
    "Planned",
    "PlannedStep",
    "Replanning",
    "ResumeTask",
    "SafeState",
    "SeenAt",
    "Sequence",
    "StepFinished",
    "StepProgress",
    "StepStarted",
    "SubmitFile",
    "SubmitGoal",
    "TaskAccepted",
    "TaskBlock",
    "TaskEvent",
    "TaskFile",
    "TaskFinished",
    "TaskHistory",
    "TaskInfo",
    "TaskOptions",
    "TaskOutcome",
    "TaskPaused",
    "TaskReply",
    "TaskRequest",
    "TaskResumed",
    "TaskStarted",
    "TaskStatus",
    "TasksReply",
    "VerifyFile",
    "VerifyProblem",
    "VerifyReply",
    "decode_event",
    "decode_operator_reply",
    "decode_operator_request",
    "decode_reply",
    "decode_request",
]

SCHEMA_VERSION = 1

# --------------------------------------------------------------------------- task files
# A TOML file such as:
#
#   name = "kit two gears"
#   [root]
#   block = "sequence"
#   [[root.children]]
#   block = "call"
#   id = "pick1"
#   agent = "r1-agent"
#   skill = "pick"
#   params = { object = "Gear-1" }
#   [[root.children]]
#   block = "call"
#   agent = "r1-agent"
#   skill = "place"
#   params = { object = "@pick1.object", container = "KitBox-1" }
#
# A parameter value "@<step id>.<param>" is data flow: the value that step ran with (including
# inferred ones). Element parameters take element ids or "label:<label>".


class Call(Struct, tag="call", tag_field="block", frozen=True, kw_only=True):
    """One skill run on one agent. ``agent`` may be empty: any agent offering ``skill``."""

    skill: str
    agent: str = ""
    params: dict[str, Value] = {}
    id: str = ""
    fallback_operator: bool = False
    """If the skill fails, ask the operator to do it (semi-autonomy)."""


class Sequence(Struct, tag="sequence", tag_field="block", frozen=True, kw_only=True):
    children: list[TaskBlock]
    id: str = ""


class Parallel(Struct, tag="parallel", tag_field="block", frozen=True, kw_only=True):
    """Children run at the same time (FRIEND II's "set of operations in parallel")."""

    children: list[TaskBlock]
    id: str = ""


TaskBlock: TypeAlias = Call | Sequence | Parallel


class TaskFile(Struct, frozen=True, kw_only=True, forbid_unknown_fields=True):
    name: str = ""
    root: TaskBlock


class VerifyProblem(Struct, frozen=True, kw_only=True):
    """One reason a task file would fail: where (``path`` of block ids / indices), what kind,
    and why."""

    path: str
    kind: Literal["dataflow", "type", "resource", "precondition", "unknown", "structure"]
    message: str
    severity: Literal["error", "warning", "note"] = "error"
    """Only errors make a file fail verification; warnings and notes are shown."""


# --------------------------------------------------------------------------- requests


class TaskOptions(Struct, frozen=True, kw_only=True):
    engine: Literal["kairos", "fast-downward"] = "kairos"
    planner_timeout: Annotated[float, Meta(gt=0)] = 30.0
    max_replans: Annotated[int, Meta(ge=0)] = 3
    simulate: bool = False
    """Run every skill in simulated-outcome mode."""
    operator_fallback: bool = False
    """When a skill fails, ask the operator before replanning."""
    operator_fallback_skills: frozenset[str] = frozenset()
    """Ask the operator only when one of these skills fails (by skill name, e.g. ``pick``);
    the others are replanned. Ignored when ``operator_fallback`` is set (every skill)."""
    priority: int = 0
    """Among tasks that wait for the same robots or objects, a higher priority goes first."""
    planning: Literal["decomposed", "monolithic"] = "decomposed"
    """``decomposed``: the goal's independent parts are allocated to agents and planned as
    small problems, falling back to the whole task when one has no plan; ``monolithic``: the
    whole task at once (:mod:`task_agent.planning`)."""
    preemptible: bool = True
    """A task of higher priority that waits for what this task holds may take it at this
    task's next step boundary; this task then waits and plans again (goals only; see
    :mod:`task_agent.claims`). With equal priorities (the default) nothing is preempted."""


class SubmitGoal(Struct, tag=True, tag_field="request", frozen=True, kw_only=True):
    """Plan and run towards ``goal`` (text like ``contain(KitBox-1, Gear-3) and ...``, or a
    :class:`~task_agent.Goal`)."""

    goal: str | Goal
    options: TaskOptions = TaskOptions()
    task_id: str = ""
    author: str = ""


class SubmitFile(Struct, tag=True, tag_field="request", frozen=True, kw_only=True):
    """Verify, then run a hand-written task (TOML text of a :class:`TaskFile`)."""

    text: str
    options: TaskOptions = TaskOptions()
    task_id: str = ""
    author: str = ""


class VerifyFile(Struct, tag=True, tag_field="request", frozen=True, kw_only=True):
    text: str


class TaskStatus(Struct, tag=True, tag_field="request", frozen=True, kw_only=True):
    task_id: str


class ListTasks(Struct, tag=True, tag_field="request", frozen=True, kw_only=True):
    active_only: bool = False


class AbortTask(Struct, tag=True, tag_field="request", frozen=True, kw_only=True):
    task_id: str
    reason: str = ""


class TaskHistory(Struct, tag=True, tag_field="request", frozen=True, kw_only=True):
    """The task's kept events with ``seq > after_seq``, oldest first, at most ``limit`` per
    reply (:class:`HistoryReply`; ask again from its last ``seq`` while ``more``)."""

    task_id: str
    after_seq: Annotated[int, Meta(ge=0)] = 0
    limit: Annotated[int, Meta(ge=1, le=5000)] = 1000


class PauseTask(Struct, tag=True, tag_field="request", frozen=True, kw_only=True):
    """Hold the task: every running run of the task is paused on its agent and no new step
    starts until ``ResumeTask`` (``AbortTask`` still works)."""

    task_id: str
    reason: str = ""


class ResumeTask(Struct, tag=True, tag_field="request", frozen=True, kw_only=True):
    task_id: str


TaskRequest: TypeAlias = (
    SubmitGoal
    | SubmitFile
    | VerifyFile
    | TaskStatus
    | ListTasks
    | AbortTask
    | TaskHistory
    | PauseTask
    | ResumeTask
)

#: The requests that read only: answered on ``tasks/query`` as well as on ``tasks/rpc``.
READ_REQUESTS = (VerifyFile, TaskStatus, ListTasks, TaskHistory)

# --------------------------------------------------------------------------- events

TaskOutcome = Literal["running", "succeeded", "failed", "unsolvable", "aborted", "partial"]
"""``partial``: an agent was lost, some goal facts became unreachable without it, and the
agents left achieved every fact still reachable (:class:`PartialResult` says which)."""


class PlannedStep(Struct, frozen=True, kw_only=True):
    index: int
    agent: str
    skill: str
    params: dict[str, Value]
    after: list[int] = []
    """Indices of the steps that must finish first (the partial order)."""
    start: float = 0.0
    finish: float = 0.0
    """Estimated seconds from the plan's start."""


class TaskStarted(Struct, tag=True, tag_field="event", frozen=True, kw_only=True):
    task_id: str
    seq: int
    stamp: float
    goal: str = ""
    name: str = ""


class Planned(Struct, tag=True, tag_field="event", frozen=True, kw_only=True):
    task_id: str
    seq: int
    stamp: float
    steps: list[PlannedStep]
    attempt: int = 0
    planner: str = ""
    plan_seconds: float = 0.0
    makespan: float = 0.0
    sequential: float = 0.0
    names: dict[str, str] = {}
    """How to name the elements the steps' parameters give by id, to a person: the label with
    the id where the two differ (``wm_store.display_name``), by id."""
    parts: int = 0
    """Parts of the goal the planner planned apart as small problems (0: the whole task)."""


class StepStarted(Struct, tag=True, tag_field="event", frozen=True, kw_only=True):
    task_id: str
    seq: int
    stamp: float
    step: int
    agent: str
    skill: str
    run_id: str
    params: dict[str, Value] = {}


class StepProgress(Struct, tag=True, tag_field="event", frozen=True, kw_only=True):
    task_id: str
    seq: int
    stamp: float
    step: int
    agent: str
    state: str
    message: str = ""
    fraction: float = -1.0


class StepFinished(Struct, tag=True, tag_field="event", frozen=True, kw_only=True):
    task_id: str
    seq: int
    stamp: float
    step: int
    agent: str
    skill: str
    success: bool
    reason: str
    message: str = ""
    by_operator: bool = False
    wm_writes: list[int] = []
    """World-model revisions the step's run (and its sub-runs) committed, from the agent's
    event log; empty when the task agent does not follow the agents' logs."""


class Replanning(Struct, tag=True, tag_field="event", frozen=True, kw_only=True):
    task_id: str
    seq: int
    stamp: float
    attempt: int
    reason: str
    """Why: the failed step's reason, or the agent that vanished."""


class FactCheck(Struct, frozen=True):
    """One goal fact after the task: in the world model, and in the physics if a simulator
    can tell."""

    fact: str
    """The goal literal, with labels: ``contain(KitBox-1, Gear-1)``, ``doorOpen(M-1) = false``."""
    in_wm: bool
    physics: bool | None = None
    """True: the physics agrees; False: it contradicts the fact; None: it cannot tell."""
    detail: str = ""
    """What the physics showed, or why it cannot tell."""

    @property
    def holds(self) -> bool:
        """In the world model, and not contradicted by the physics."""
        return self.in_wm and self.physics is not False


class GoalCheck(Struct, frozen=True, kw_only=True):
    """Every goal fact of a succeeded goal task, checked once the plan ran."""

    facts: list[FactCheck] = []
    simulator: bool = False
    """A simulator answered (``sim/truth``); else the facts were checked in the world model only."""
    sim_time: float | None = None
    """Simulated time, s, at the check (with a simulator)."""
    note: str = ""
    """Why the physics was not asked (``no simulator on the mesh: ...``), or what it said."""

    @property
    def holds(self) -> bool:
        """Every fact holds in the world model and none is contradicted by the physics."""
        return bool(self.facts) and all(f.holds for f in self.facts)

    @property
    def contradicted(self) -> list[FactCheck]:
        """The facts the world model holds but the physics contradicts."""
        return [f for f in self.facts if f.in_wm and f.physics is False]


class LostAgent(Struct, frozen=True, kw_only=True):
    """An agent lost while the task ran (its liveliness token gone, or out of reach for longer
    than the grace period)."""

    agent: str
    step: int = -1
    """The step it was running when lost (-1: none)."""
    skill: str = ""
    message: str = ""


class LostFact(Struct, frozen=True, kw_only=True):
    """A goal fact the agents left cannot reach."""

    fact: str
    """With labels, as in :class:`FactCheck`."""
    why: str


class PartialResult(Struct, frozen=True, kw_only=True):
    """What a task that lost an agent achieved (outcome ``partial``; ``failed`` when it
    achieved none of the goal's facts)."""

    achieved: list[str] = []
    """The goal facts that hold at the end (with labels)."""
    lost: list[LostFact] = []
    lost_agents: list[LostAgent] = []


class SafeState(Struct, tag=True, tag_field="event", frozen=True, kw_only=True):
    """The task ended unfinished: one robot of the task put down what it held (``ok``), or
    could not (``message`` says why). Its put-down runs are ordinary steps (``StepStarted``,
    ``StepFinished``), numbered after the task's last step."""

    task_id: str
    seq: int
    stamp: float
    agent: str
    holding: list[str] = []
    """What it held (labels) when the task ended."""
    ok: bool = False
    message: str = ""


class TaskFinished(Struct, tag=True, tag_field="event", frozen=True, kw_only=True):
    task_id: str
    seq: int
    stamp: float
    outcome: TaskOutcome
    message: str = ""
    steps_run: int = 0
    replans: int = 0
    duration: float = 0.0
    check: GoalCheck | None = None
    """A succeeded goal task: each goal fact in the world model and in the physics."""
    partial: PartialResult | None = None
    """A task that lost an agent and could not reach every goal fact without it."""
    estimated_makespan: float | None = None
    """The first plan's makespan, s (None: nothing was planned)."""
    actual_makespan: float | None = None
    """From the first plan to the end of the task's last step, s (the task agent's clock)."""


class TaskPaused(Struct, tag=True, tag_field="event", frozen=True, kw_only=True):
    """The task is held (``PauseTask``): no new step starts; ``runs`` were paused on their
    agents (``agent/run``). Also when a task of higher priority preempted the task at a step
    boundary (``reason`` says which; no run is paused: none was running); ``TaskResumed``
    follows once the task holds its claim again."""

    task_id: str
    seq: int
    stamp: float
    reason: str = ""
    runs: list[str] = []


class TaskResumed(Struct, tag=True, tag_field="event", frozen=True, kw_only=True):
    """The task goes on (``ResumeTask``): its paused runs were resumed."""

    task_id: str
    seq: int
    stamp: float
    runs: list[str] = []


TaskEvent: TypeAlias = (
    TaskStarted
    | Planned
    | StepStarted
    | StepProgress
    | StepFinished
    | Replanning
    | TaskPaused
    | TaskResumed
    | SafeState
    | TaskFinished
)

# --------------------------------------------------------------------------- replies


class TaskInfo(Struct, frozen=True, kw_only=True):
    task_id: str
    outcome: TaskOutcome
    goal: str = ""
    name: str = ""
    started_at: float = 0.0
    finished_at: float = 0.0
    replans: int = 0
    steps_run: int = 0
    message: str = ""
    check: GoalCheck | None = None
    """As in :class:`TaskFinished`, once the task has ended."""
    paused: bool = False
    """Held by ``PauseTask`` (no new step starts) until ``ResumeTask``."""
    partial: PartialResult | None = None
    """As in :class:`TaskFinished`, once the task has ended."""
    priority: int = 0
    claims: list[str] = []
    """The agents and objects the running task holds (no other task commands them)."""
    waiting: str = ""
    """What the task waits for before its steps can start (held by another task)."""
    estimated_makespan: float | None = None
    """As in :class:`TaskFinished` (the first plan's makespan, once planned)."""
    actual_makespan: float | None = None
    """As in :class:`TaskFinished`, once the task has ended."""


class TaskAccepted(Struct, tag=True, tag_field="reply", frozen=True, kw_only=True):
    task_id: str
    schema_version: int = SCHEMA_VERSION


class TasksReply(Struct, tag=True, tag_field="reply", frozen=True, kw_only=True):
    tasks: list[TaskInfo]
    schema_version: int = SCHEMA_VERSION


class VerifyReply(Struct, tag=True, tag_field="reply", frozen=True, kw_only=True):
    ok: bool
    problems: list[VerifyProblem] = []
    schema_version: int = SCHEMA_VERSION


class OkReply(Struct, tag=True, tag_field="reply", frozen=True, kw_only=True):
    message: str = ""
    schema_version: int = SCHEMA_VERSION


class HistoryReply(Struct, tag=True, tag_field="reply", frozen=True, kw_only=True):
    """A task's kept events (``TaskHistory``), oldest first. ``dropped``: events the task
    agent did not keep (its bound per task: progress events go first); ``more``: events after
    the last one here did not fit in this reply."""

    task_id: str
    events: list[TaskEvent]
    outcome: TaskOutcome = "running"
    dropped: int = 0
    more: bool = False
    schema_version: int = SCHEMA_VERSION


TaskReply: TypeAlias = TaskAccepted | TasksReply | VerifyReply | OkReply | HistoryReply | ErrorReply

# --------------------------------------------------------------------------- operator
# ``operator/rpc``: one OperatorRequest -> one OperatorReply (errors: ErrorReply, code
# ``unknown_request`` for an id that is not pending).


class PendingStep(Struct, frozen=True, kw_only=True):
    """A skill run the operator agent holds until a person answers it."""

    id: str
    """Short, for typing: ``skimesh operator --answer <id> success``."""
    run_id: str
    skill: str
    params: dict[str, Value] = {}
    note: str = ""
    """What failed and what to do (from the executor)."""
    asked_at: float = 0.0


class ListPending(Struct, tag=True, tag_field="request", frozen=True, kw_only=True):
    pass


class SeenAt(Struct, frozen=True, kw_only=True):
    """Where a person sees an element (FRIEND II: the user as a sensor when the machine's
    sensors fail): the world position of its centre, m, and optionally its heading, rad."""

    element: str
    """Element id or label."""
    position: tuple[float, float, float]
    yaw: float | None = None
    """None: keep the orientation the world model has."""
    confidence: Annotated[float, Meta(ge=0, le=1)] = 0.9


class AnswerPending(Struct, tag=True, tag_field="request", frozen=True, kw_only=True):
    """The person's answer: the step is done (``success``) or cannot be done. ``seen``: where
    the person sees elements; written as pose observations by the operator (source: the
    ``Operator`` element), which ``locate`` uses when no sensor sees the object."""

    id: str
    success: bool
    message: str = ""
    author: str = ""
    seen: list[SeenAt] = []


class PendingReply(Struct, tag=True, tag_field="reply", frozen=True, kw_only=True):
    agent: str
    pending: list[PendingStep]
    schema_version: int = SCHEMA_VERSION


OperatorRequest: TypeAlias = ListPending | AnswerPending
OperatorReply: TypeAlias = PendingReply | OkReply | ErrorReply

# --------------------------------------------------------------------------- codecs
# ``encode`` and ``ErrorReply`` are :mod:`meshlink.rpc`'s (the task service speaks the shared
# RPC wire); every ``decode_*`` raises only :class:`meshlink.rpc.WireError`.

_request: Decoder[TaskRequest] = Decoder(TaskRequest, what="request")
_reply: Decoder[TaskReply] = Decoder(TaskReply, what="reply")
_event: Decoder[TaskEvent] = Decoder(TaskEvent, what="task event")
_operator_request: Decoder[OperatorRequest] = Decoder(OperatorRequest, what="operator request")
_operator_reply: Decoder[OperatorReply] = Decoder(OperatorReply, what="operator reply")


def decode_request(data: bytes) -> TaskRequest:
    return _request.decode(data)


def decode_reply(data: bytes) -> TaskReply:
    return _reply.decode(data)


def decode_event(data: bytes) -> TaskEvent:
    return _event.decode(data)


def decode_operator_request(data: bytes) -> OperatorRequest:
    return _operator_request.decode(data)


def decode_operator_reply(data: bytes) -> OperatorReply:
    return _operator_reply.decode(data)
