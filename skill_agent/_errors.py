"""Errors of the skill layer. Every exception raised by ``skill_agent`` derives from
:class:`SkillError`.

Hierarchy::

    SkillError
    ├── SkillLoadError             a skill plug-in cannot be imported or fails its checks at load
    │   └── WiringError            a configured device label names no element, or several
    │                              (skill_agent.runtime)
    ├── UnknownSkillError          no skill of that name on this agent (names the closest)
    ├── ParameterError             the parameters of a start request are wrong
    │   ├── UnknownParameterError  a parameter the skill does not have
    │   ├── ParameterTypeError     a value of the wrong kind, or an element of the wrong class
    │   ├── UnspecifiedParameterError  a required parameter is missing and cannot be inferred
    │   └── InferenceError         inference found no candidate, or could not rank them
    ├── ResourceBusyError          a device the run needs is used by another run
    ├── PreconditionError          a pre-condition is false (start refused, nothing moved)
    ├── UnknownRunError            no run with that id
    ├── RunStateError              the run cannot do that now (e.g. resume a run not paused)
    ├── SkillFailure               raised by skill code: the skill could not do its job
    ├── NoGraspError               no grasp fits the object (skill_agent.primitives; the skills
    │                              that plan grasps turn it into a failed run)
    ├── BadRequestError            no valid request (garbage, unknown tag, types, too large)
    ├── AgentInternalError         the agent failed unexpectedly while answering (a bug; logged)
    ├── AgentTransportError        the agent cannot be reached
    └── RemoteSkillError           the agent answered with an error (keeps its code)

Each class has a stable ``code`` used on the wire (:class:`skill_agent.protocol.ErrorReply`).
A :class:`ParameterError` refusing a start because parameters could not all be specified also
carries every parameter's state (``param_states``: ``initialized`` / ``specified``), on the
wire too.
"""

from __future__ import annotations

from collections.abc import Mapping

from meshlink import rpc
from meshlink.rpc import (
    BAD_REQUEST,
    INTERNAL,
    TOO_LARGE,
    UNAVAILABLE,
    Decoder,
    ErrorFactory,
    decode_error,
    error_for,
    errors_by_code,
    from_message,
)
from skill_agent.protocol._runs import ErrorReply
from skill_agent.protocol._skills import ParamState

__all__ = [
    "AGENT_CODES",
    "AgentInternalError",
    "AgentTransportError",
    "BadRequestError",
    "InferenceError",
    "ParameterError",
    "ParameterTypeError",
    "PreconditionError",
    "RemoteSkillError",
    "ResourceBusyError",
    "RunStateError",
    "SkillError",
    "SkillFailure",
    "SkillLoadError",
    "UnknownParameterError",
    "UnknownRunError",
    "UnknownSkillError",
    "UnspecifiedParameterError",
    "error_for_reply",
    "leaves",
]


class SkillError(Exception):
    code: str = "skill_error"


class SkillLoadError(SkillError):
    code = "skill_load"


class UnknownSkillError(SkillError):
    code = "unknown_skill"


class ParameterError(SkillError):
    code = "parameter"

    def __init__(
        self, message: str, *, param_states: Mapping[str, ParamState] | None = None
    ) -> None:
        super().__init__(message)
        self.param_states: dict[str, ParamState] = dict(param_states or {})
        """Every parameter's state when the start was refused ({} when not about that)."""


class UnknownParameterError(ParameterError):
    code = "unknown_parameter"


class ParameterTypeError(ParameterError):
    code = "parameter_type"


class UnspecifiedParameterError(ParameterError):
    code = "unspecified_parameter"


class InferenceError(ParameterError):
    code = "inference"


class ResourceBusyError(SkillError):
    code = "resource_busy"


class PreconditionError(SkillError):
    code = "precondition"


class UnknownRunError(SkillError):
    code = "unknown_run"


class RunStateError(SkillError):
    code = "run_state"


class SkillFailure(SkillError):
    """Raise from ``execute`` / sensing when the skill cannot do its job (the run fails with
    reason ``execution`` and this message)."""

    code = "skill_failure"


class BadRequestError(SkillError):
    code = BAD_REQUEST


class AgentInternalError(SkillError):
    code = INTERNAL


class AgentTransportError(SkillError):
    code = "agent_transport"


class RemoteSkillError(SkillError):
    code = "remote_error"

    def __init__(self, remote_code: str, message: str) -> None:
        super().__init__(f"[{remote_code}] {message}")
        self.remote_code = remote_code
        self.message = message


def _with_param_states(cls: type[ParameterError]) -> ErrorFactory:
    return lambda r: cls(r.message, param_states=getattr(r, "param_states", None))


AGENT_CODES: dict[str, ErrorFactory] = {
    **errors_by_code(
        SkillError,
        SkillLoadError,
        UnknownSkillError,
        ResourceBusyError,
        PreconditionError,
        UnknownRunError,
        RunStateError,
        SkillFailure,
        BadRequestError,
        AgentInternalError,
        AgentTransportError,
    ),
    **{
        cls.code: _with_param_states(cls)
        for cls in (
            ParameterError,
            UnknownParameterError,
            ParameterTypeError,
            UnspecifiedParameterError,
            InferenceError,
        )
    },
    TOO_LARGE: from_message(BadRequestError),
    UNAVAILABLE: lambda r: RemoteSkillError("remote_error", r.message),
}
"""Error code -> the local exception, for :func:`meshlink.rpc.error_for` (a ParameterError
with the ``param_states`` the reply carried). The standard codes: ``bad_request`` and
``too_large`` give :class:`BadRequestError`, ``internal`` :class:`AgentInternalError`; an
error payload that is no ErrorReply (``unavailable``) a :class:`RemoteSkillError` with code
``remote_error``; an unknown code: see :func:`error_for_reply`."""

_error_reply: Decoder[ErrorReply] = Decoder(ErrorReply, what="error reply")


def error_for_reply(error: rpc.ErrorReply | bytes) -> SkillError:
    """The local exception for an agent's error reply, or for an error reply's payload (a
    :class:`RemoteSkillError` that keeps an unknown code)."""
    reply = decode_error(error, _error_reply) if isinstance(error, bytes) else error
    found = error_for(reply, AGENT_CODES, fallback=_unknown_code)
    return found if isinstance(found, SkillError) else _unknown_code(reply)


def _unknown_code(error: rpc.ErrorReply) -> RemoteSkillError:
    return RemoteSkillError(error.code, error.message)


def leaves(exc: BaseException) -> list[BaseException]:
    """The exceptions in ``exc``, exception groups flattened."""
    if isinstance(exc, BaseExceptionGroup):
        return [leaf for sub in exc.exceptions for leaf in leaves(sub)]
    return [exc]
