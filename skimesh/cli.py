"""The ``skimesh`` command: one entry point for every service and tool.

Run ``skimesh --help`` for the list; every sub-command has its own ``--help``.

Start-up time: ``skimesh --help`` and ``--version`` import no command module (the list below
names each command with its one-line help), and a command imports only the module that adds
it (:data:`COMMANDS`); errors are classified (:mod:`skimesh.errors`) only when one happened.
"""

from __future__ import annotations

import argparse
import importlib
import logging
import sys
from collections.abc import Sequence

__all__ = [
    "COMMANDS",
    "CONNECTION_OPTIONS",
    "build_parser",
    "describe_error",
    "hoist_connection_options",
    "main",
]

#: Every top-level command, in the order of ``skimesh --help``: the module of
#: :mod:`skimesh.commands` that adds it (its ``add_parser``) and its one-line help, the same as
#: that module's (a test compares them).
COMMANDS: dict[str, tuple[str, str]] = {
    "router": (
        "router",
        "run a Zenoh router (one per site or host; agents and tools connect to it)",
    ),
    "wm": ("wm", "run the world-model store, or read/write it (ls, get, tree, query, ...)"),
    "agent": (
        "agent",
        "run the skill agent of a robot or smart device (or several, in one process)",
    ),
    "agents": ("agent", "list skill agents: alive (liveliness) and in the WM"),
    "skills": ("agent", "list the skills of one agent or of all agents"),
    "run": ("agent", "run a skill on an agent and stream its progress until the result"),
    "reload": ("agent", "re-import an agent's skill plug-ins (runs in flight keep their code)"),
    "stop": ("agent", "stop a run (the skill brings its hardware to safety)"),
    "runs": (
        "agent",
        "list the runs of the agents, or show one run and its history (--follow)",
    ),
    "pause": ("agent", "hold a run at its next checkpoint (`skimesh runs` lists the runs)"),
    "resume": ("agent", "resume it (`skimesh runs` lists the runs)"),
    "demo": ("demo", "the whole mission in one process, on loopback"),
    "sim": ("sim", "simulate a scenario's world and serve its devices on the mesh"),
    "task-agent": (
        "task",
        "run the task agent: planning, multi-robot execution, the operator agent",
    ),
    "task": ("task", "submit, follow, list and abort tasks"),
    "operator": ("task", "list the steps waiting for a person and answer them (semi-autonomy)"),
    "eventlog": (
        "events",
        "keep the site event log (every task, run, agent, device and world-model event)",
    ),
    "events": (
        "events",
        "filter, follow and export the site event log (`skimesh eventlog` keeps it)",
    ),
    "up": (
        "site",
        "bring up this host's part of a site (SITE.toml): health checks, restarts, logs",
    ),
    "down": ("site", "stop the site `skimesh up` runs on this host"),
    "status": ("site", "the state of each component of a site"),
    "monitor": (
        "monitor",
        "follow a running site into rerun: world, tasks, plan, changes, agents' logs",
    ),
}

#: Every command module, in the order they add their commands.
MODULES = ("router", "wm", "agent", "demo", "sim", "task", "events", "site", "monitor")


class _Version(argparse.Action):
    """``--version``: reads the installed version only when asked (importlib.metadata is slow
    to import, and every start would pay for it)."""

    def __init__(self, option_strings: Sequence[str], dest: str, help: str) -> None:
        super().__init__(option_strings, dest, nargs=0, default=argparse.SUPPRESS, help=help)

    def __call__(self, parser: argparse.ArgumentParser, *_: object) -> None:
        from importlib import metadata

        try:
            version = metadata.version("skimesh")
        except metadata.PackageNotFoundError:  # a source tree that was never installed
            version = "unknown (not installed)"
        print(f"skimesh {version}")
        parser.exit()


def build_parser(argv: Sequence[str] | None = None) -> argparse.ArgumentParser:
    """The parser of every command; given the command line ``argv``, only what it needs: the
    module of the command it names, or the list of commands alone when it names none (or one
    no module is known to add: then every module, as without ``argv``)."""
    parser = argparse.ArgumentParser(
        prog="skimesh",
        description="skimesh: a Zenoh-distributed multi-robot skill mesh. Start with "
        "`skimesh demo`; run services on several hosts with `router`, `wm`, ... and "
        "`--connect tcp/HOST:7447` (the connection options --connect, --mesh, --config and "
        "--timeout may come before or after a command). Exit codes: 0 ok, 1 failed, "
        "2 refused (usage, bad input, unknown name), 3 unreachable (no reply in time), "
        "4 aborted, 5 the physics contradicts the world model, 6 partial, 130 interrupted.",
    )
    parser.add_argument(
        "-v", "--verbose", action="count", default=0, help="more log output (-vv: debug)"
    )
    parser.add_argument(
        "--debug",
        action="store_true",
        help="show the traceback of an error (by default: one line saying what went wrong)",
    )
    parser.add_argument("--version", action=_Version, help="print the version and exit")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    named = _command_in(argv) if argv is not None else None
    wanted: tuple[str, ...] = () if argv is not None and named is None else MODULES
    if named in COMMANDS:
        wanted = (COMMANDS[named][0],)
    for module in MODULES:
        if module in wanted:
            importlib.import_module(f".commands.{module}", __package__).add_parser(sub)
        else:  # only listed (--help, --version, a usage error): not run
            for name, (where, text) in COMMANDS.items():
                if where == module:
                    sub.add_parser(name, help=text)
    return parser


#: The options of the mesh and its requests, which every client command takes: given before the
#: command (``skimesh --connect E agents``) they are moved after it, where its parser reads them.
CONNECTION_OPTIONS = frozenset(
    {"--connect", "--listen", "--config", "--mesh", "--mode", "--timeout"}
)


def hoist_connection_options(argv: Sequence[str]) -> list[str]:
    """``argv`` with the connection options found before the command word moved just after
    it (``skimesh --connect E task list`` reads as ``skimesh task --connect E list``); a
    command that takes none refuses them as any unknown option."""
    head: list[str] = []
    moved: list[str] = []
    rest = list(argv)
    while rest and rest[0].startswith("-"):
        word = rest.pop(0)
        if word.split("=", 1)[0] in CONNECTION_OPTIONS:
            moved.append(word)
            if "=" not in word and rest:
                moved.append(rest.pop(0))
        else:
            head.append(word)
    if not rest or not moved:
        return list(argv)
    return [*head, rest[0], *moved, *rest[1:]]


def _command_in(argv: Sequence[str]) -> str | None:
    """The command ``argv`` names: its first word that is no option (the global options take
    no value), or None."""
    return next((arg for arg in argv if not arg.startswith("-")), None)


#: The long-running commands: the INFO lines of their own loggers (ready, stopped, ...) show by
#: default; a client command shows warnings and errors only.
_SERVICES = frozenset({"router", "wm", "sim", "agent", "task-agent", "eventlog", "monitor"})
_SERVICE_LOGGERS = ("skimesh", "skill_agent.server", "task_agent.service", "task_agent.operator")


def _is_service(args: argparse.Namespace) -> bool:
    return args.command in _SERVICES and not getattr(args, "wm_command", None)


def describe_error(error: BaseException) -> str:
    """One line for a user: the message, or the kind of error where it has none (a bare
    ``TimeoutError`` says nothing by itself)."""
    text = str(error.code) if isinstance(error, SystemExit) else str(error)
    if isinstance(error, TimeoutError) and not text:
        return "timed out (no answer in time; is the router reachable and the service running?)"
    return text or type(error).__name__


def _leaves(error: BaseException) -> list[BaseException]:
    if isinstance(error, BaseExceptionGroup):
        return [leaf for e in error.exceptions for leaf in _leaves(e)]
    return [error]


def main(argv: Sequence[str] | None = None) -> int:
    """Run one command; its exit code (:class:`skimesh.errors.Exit`). An error a user can act
    on is one line on stderr (with its traceback under ``--debug``); any other error is a bug
    and shows its traceback."""
    argv = sys.argv[1:] if argv is None else argv
    debug = "--debug" in argv  # before or after the command, as the connection options
    argv = hoist_connection_options([arg for arg in argv if arg != "--debug"])
    args = build_parser(argv).parse_args(argv)
    args.debug = debug
    _configure_logging(args)
    try:
        return int(args.func(args))
    except KeyboardInterrupt:
        return 130  # Exit.INTERRUPTED
    except BaseException as error:
        return _one_line(error, args)  # or raises it again: a bug


def _configure_logging(args: argparse.Namespace) -> None:
    from .runtime import configure_logging

    configure_logging(args.verbose)
    if _is_service(args) and not args.verbose:  # a service says it is ready, as ROS 2 nodes do
        for name in _SERVICE_LOGGERS:
            logging.getLogger(name).setLevel(logging.INFO)
    if not args.debug:
        for handler in logging.getLogger().handlers:
            handler.addFilter(_expected_in_one_line)


def _expected_in_one_line(record: logging.LogRecord) -> bool:
    """A log record of an expected error (a device that does not answer, an unknown name: one
    of :func:`skimesh.errors.user_errors`) says it in one line, without its traceback (shown
    with ``skimesh --debug``); a bug's traceback stays."""
    error = record.exc_info[1] if record.exc_info else None
    if error is None:
        return True
    from .errors import user_errors

    if all(isinstance(leaf, user_errors()) for leaf in _leaves(error)):
        said = "; ".join(f"{type(e).__name__}: {describe_error(e)}" for e in _leaves(error))
        record.msg, record.args = f"{record.getMessage()}: {said}", ()
        record.exc_info, record.exc_text = None, None
    return True


def _one_line(error: BaseException, args: argparse.Namespace) -> int:
    """An error a user can act on, as one line per error on stderr; its exit code. Any other
    error (a bug, a SystemExit with a code) propagates."""
    from .errors import Exit, complain, exit_code, user_errors

    known = user_errors()

    leaves = _leaves(error)
    usage = [isinstance(e, SystemExit) and isinstance(e.code, str) for e in leaves]
    if not all(u or isinstance(e, known) for e, u in zip(leaves, usage, strict=True)):
        raise error
    if args.debug:
        import traceback

        traceback.print_exception(error)
    for leaf in leaves:
        complain(args, describe_error(leaf))
    return max(Exit.REFUSED if u else exit_code(e) for e, u in zip(leaves, usage, strict=True))


if __name__ == "__main__":
    sys.exit(main())
