"""The errors of the skimesh application and the one exit-code table of every command.

:class:`SkimeshError` is the root of the application's errors. :class:`Exit` is what every
``skimesh`` command exits with (the README's "Exit codes" table), and :func:`exit_code` tells
which code an error a user can act on gets; :func:`user_errors` are those errors (the packages'
roots): the command line prints them as one line, with a traceback only under ``--debug``.
"""

from __future__ import annotations

from enum import IntEnum

__all__ = [
    "DemoError",
    "Exit",
    "SkimeshError",
    "UsageError",
    "complain",
    "exit_code",
    "user_errors",
]


class Exit(IntEnum):
    """The exit code of every ``skimesh`` command."""

    OK = 0
    """Done: the task or run succeeded, the element was found, the service stopped cleanly."""
    FAILED = 1
    """The mesh did what was asked and it did not succeed: a task or skill run failed, a check
    found unmet conditions, a query matched nothing, the planner failed, a service failed."""
    REFUSED = 2
    """Nothing ran: a usage error, bad input, an unknown name (element, agent, skill, class),
    or a request refused before it started (a false pre-condition, a busy device, a goal no
    plan reaches)."""
    UNREACHABLE = 3
    """The mesh, the world model, an agent, a device or the task agent did not answer in time."""
    ABORTED = 4
    """The task was aborted (``task abort``, the operator) before it ended."""
    CONTRADICTED = 5
    """The task succeeded in the world model but the physics contradicts it."""
    PARTIAL = 6
    """The task ended ``partial``: an agent was lost; the goal facts still reachable were
    achieved, the others lost (the report says which and why)."""
    INTERRUPTED = 130
    """Ctrl-C or SIGTERM stopped the command (a run in flight is stopped)."""


class SkimeshError(Exception):
    """Root of the skimesh application's errors."""


class DemoError(SkimeshError):
    """The demo cannot start (a busy data directory, a scenario without agents, ...)."""


class UsageError(SkimeshError):
    """A command line or input file the command cannot use (exit :attr:`Exit.REFUSED`)."""


def complain(args: object, text: str) -> None:
    """Say what went wrong on stderr, as every command does: ``skimesh task submit: TEXT``
    (the command's words from the parsed ``args``)."""
    import sys

    words = ["skimesh"] + [
        str(getattr(args, dest))
        for dest in ("command", "task_command", "wm_command")
        if getattr(args, dest, None)
    ]
    print(f"{' '.join(words)}: {text}", file=sys.stderr)


def user_errors() -> tuple[type[Exception], ...]:
    """The errors a user can act on (the packages' roots): one line on stderr and the code
    :func:`exit_code` gives. Imported when an error happened (start-up time)."""
    from device_drivers import DeviceError
    from meshlink import MeshlinkError
    from skill_agent import SkillError
    from task_agent import TaskError
    from wm_store import WmError

    return (MeshlinkError, WmError, SkillError, TaskError, DeviceError, SkimeshError, OSError)


def exit_code(error: BaseException) -> Exit:
    """The code of an error: unreachable for no reply in time, refused for bad input and
    unknown names, failed for what ran and did not succeed (:class:`Exit`)."""
    from device_drivers import DeviceUnavailableError
    from meshlink import MeshlinkError, NoReplyError, SessionError
    from meshlink.rpc import BAD_REQUEST, INTERNAL, TOO_LARGE, UNAVAILABLE
    from skill_agent import AgentTransportError, RemoteSkillError, SkillError, SkillFailure
    from task_agent import (
        PlanningError,
        RemoteTaskError,
        RequestError,
        TaskError,
        TaskTransportError,
        UnsolvableError,
    )
    from wm_store import OntologyError, TransportError, ValidationError
    from wm_store import RemoteError as WmRemoteError

    by_wire_code = {  # a service's error reply by its generic code
        BAD_REQUEST: Exit.REFUSED,
        TOO_LARGE: Exit.REFUSED,
        INTERNAL: Exit.FAILED,
        UNAVAILABLE: Exit.UNREACHABLE,
    }
    if isinstance(error, RequestError | RemoteTaskError):  # other codes name what was refused
        return by_wire_code.get(error.code, Exit.REFUSED)  # (an unknown task, a taken id)
    if isinstance(error, RemoteSkillError | WmRemoteError):
        return by_wire_code.get(error.remote_code, Exit.FAILED)
    kinds: tuple[tuple[type[BaseException], Exit], ...] = (  # the most specific first
        (NoReplyError, Exit.UNREACHABLE),
        (SessionError, Exit.UNREACHABLE),
        (TransportError, Exit.UNREACHABLE),
        (AgentTransportError, Exit.UNREACHABLE),
        (TaskTransportError, Exit.UNREACHABLE),
        (DeviceUnavailableError, Exit.UNREACHABLE),
        (TimeoutError, Exit.UNREACHABLE),
        (ConnectionError, Exit.UNREACHABLE),
        (SkillFailure, Exit.FAILED),
        (UnsolvableError, Exit.REFUSED),
        (PlanningError, Exit.FAILED),
        (ValidationError, Exit.REFUSED),
        (OntologyError, Exit.REFUSED),
        (SkillError, Exit.REFUSED),
        (TaskError, Exit.REFUSED),
        (SkimeshError, Exit.REFUSED),
        (FileNotFoundError, Exit.REFUSED),
        (MeshlinkError, Exit.REFUSED),
    )
    for kind, code in kinds:
        if isinstance(error, kind):
            return code
    return Exit.FAILED  # a storage fault, a service's internal error, a device's fault
