"""Errors of the task layer. Every exception raised by ``task_agent`` derives from
:class:`TaskError`.

Hierarchy::

    TaskError
    ├── GoalParseError           a goal is malformed or names something the world model lacks:
    │                            syntax (with the column), unknown element (closest ids),
    │                            unknown relation or property (closest names), wrong arity,
    │                            a value of the wrong kind, an ambiguous label
    ├── DiscoveryError           an agent's registration in the world model cannot be read
    ├── PlanningError            no plan came out
    │   ├── DomainError          nothing to plan with: no agent, no skill with a symbolic face
    │   ├── UnsolvableError      the goal cannot be reached from the current world model
    │   │                        (``reason``; ``unreachable``: the goal facts no sequence of
    │   │                        skills can make true, when the analysis can tell)
    │   └── PlannerTimeoutError  the planner ran out of time
    ├── VerificationError        a task structure fails its checks (data flow, types,
    │   │                        resources, pre-condition chain)
    │   └── FileRefusedError     a submitted task file did not verify (``problems``)
    ├── StepInputError           a step's parameters cannot be resolved when it starts (data
    │                            flow, label): the step fails with reason ``dataflow``
    ├── RequestError             the task service refused a request (``code``: unknown_task,
    │                            task_exists, bad_request, unknown_request, ...)
    ├── RemoteTaskError          an error reply whose code has no class here (keeps ``code``)
    └── TaskTransportError       the task agent cannot be reached, stopped answering, or sent
                                 garbage

Each class has a stable ``code`` for the wire (the task service's error replies);
:data:`TASK_CODES` turns an error reply back into its class (clients).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

from meshlink.rpc import UNAVAILABLE, ErrorFactory, ErrorReply, errors_by_code

if TYPE_CHECKING:
    from .protocol import VerifyProblem

__all__ = [
    "TASK_CODES",
    "DiscoveryError",
    "DomainError",
    "FileRefusedError",
    "GoalParseError",
    "PlannerTimeoutError",
    "PlanningError",
    "RemoteTaskError",
    "RequestError",
    "StepInputError",
    "TaskError",
    "TaskTransportError",
    "UnsolvableError",
    "VerificationError",
    "remote_task_error",
]


class TaskError(Exception):
    code: str = "task_error"


class GoalParseError(TaskError):
    """``column`` is the 1-based position in the goal text (0 when the goal was a Struct)."""

    code = "goal_parse"

    def __init__(self, message: str, *, column: int = 0) -> None:
        super().__init__(message)
        self.column = column


class DiscoveryError(TaskError):
    code = "discovery"


class PlanningError(TaskError):
    code = "planning"


class DomainError(PlanningError):
    code = "domain"


class UnsolvableError(PlanningError):
    """``proven``: the engine proved that no plan exists (else it only found none)."""

    code = "unsolvable"

    def __init__(
        self, reason: str, *, unreachable: Sequence[str] = (), proven: bool = False
    ) -> None:
        super().__init__(reason)
        self.reason = reason
        self.unreachable = tuple(unreachable)
        self.proven = proven


class PlannerTimeoutError(PlanningError):
    code = "planner_timeout"

    def __init__(self, message: str, *, timeout: float = 0.0) -> None:
        super().__init__(message)
        self.timeout = timeout


class VerificationError(TaskError):
    code = "verification"


_BY_CODE = errors_by_code(
    TaskError,
    GoalParseError,
    DiscoveryError,
    PlanningError,
    DomainError,
    UnsolvableError,
    PlannerTimeoutError,
    VerificationError,
)


class FileRefusedError(VerificationError):
    """A submitted task file failed verification; ``problems`` says why."""

    def __init__(self, problems: Sequence[VerifyProblem]) -> None:
        lines = "; ".join(f"{p.path or '-'} [{p.kind}] {p.message}" for p in problems)
        super().__init__(f"the task file does not verify ({len(problems)} problems): {lines}")
        self.problems = list(problems)


class StepInputError(TaskError):
    """A step's parameters cannot be resolved (data flow, label)."""


class RequestError(TaskError):
    """A refused request, with its wire ``code`` (``unknown_task``, ``task_exists``, ...)."""

    def __init__(self, code: str, message: str) -> None:
        super().__init__(message)
        self.code = code


class RemoteTaskError(TaskError):
    """An error reply whose code has no class here; ``code`` is the wire code."""

    def __init__(self, code: str, message: str) -> None:
        super().__init__(message)
        self.code = code


class TaskTransportError(TaskError):
    """The task agent cannot be reached, stopped answering, or sent garbage."""

    code = "transport"


TASK_CODES: dict[str, ErrorFactory] = {
    **_BY_CODE,
    UNAVAILABLE: lambda reply: TaskTransportError(reply.message),
}
"""Error reply code -> the exception a client raises (``unavailable``: the error payload was
no ErrorReply, e.g. plain text from a server that stopped). Other codes (the standard
``bad_request``, ``too_large``, ``internal``, and ``task_exists``, ``unknown_task``, ...)
raise :func:`remote_task_error`'s :class:`RemoteTaskError`, which keeps the code."""


def remote_task_error(reply: ErrorReply) -> TaskError:
    """The fallback of :data:`TASK_CODES`: :class:`RemoteTaskError` with the reply's code."""
    return RemoteTaskError(reply.code, reply.message)
