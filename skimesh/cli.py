"""The ``skimesh`` command: one entry point for every service and tool.

Run ``skimesh --help`` for the list; every sub-command has its own ``--help``.
"""

from __future__ import annotations

import argparse
import logging
import sys
import traceback
from collections.abc import Sequence

from .commands import agent, demo, router, sim, task, wm
from .errors import USER_ERRORS, Exit, exit_code
from .runtime import configure_logging

__all__ = ["build_parser", "describe_error", "main"]


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


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="skimesh",
        description="skimesh: a Zenoh-distributed multi-robot skill mesh. Start with "
        "`skimesh demo`; run services on several hosts with `router`, `wm`, ... and "
        "`--connect tcp/HOST:7447`. Exit codes: 0 ok, 1 failed, 2 refused (usage, bad input, "
        "unknown name), 3 unreachable (no reply in time), 4 aborted, 5 the physics "
        "contradicts the world model, 130 interrupted.",
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
    router.add_parser(sub)
    wm.add_parser(sub)
    agent.add_parser(sub)
    demo.add_parser(sub)
    sim.add_parser(sub)
    task.add_parser(sub)
    return parser


#: The long-running commands: the INFO lines of their own loggers (ready, stopped, ...) show by
#: default; a client command shows warnings and errors only.
_SERVICES = frozenset({"router", "wm", "sim", "agent", "task-agent"})
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
    parser = build_parser()
    args = parser.parse_args(argv)
    configure_logging(args.verbose)
    if _is_service(args) and not args.verbose:  # a service says it is ready, as ROS 2 nodes do
        for name in _SERVICE_LOGGERS:
            logging.getLogger(name).setLevel(logging.INFO)
    try:
        return int(args.func(args))
    except KeyboardInterrupt:
        return Exit.INTERRUPTED
    except (*USER_ERRORS, SystemExit, BaseExceptionGroup) as error:  # type: ignore[misc]  # a tuple: mypy misreads the unpacking
        leaves = _leaves(error)
        if not all(_for_the_user(leaf) for leaf in leaves):
            raise
        if args.debug:
            traceback.print_exc()
        for leaf in leaves:
            print(f"skimesh {args.command}: {describe_error(leaf)}", file=sys.stderr)
        return max(_code(leaf) for leaf in leaves)


def _for_the_user(error: BaseException) -> bool:
    """An error a user can act on: one of :data:`USER_ERRORS`, or a command's usage error as
    text (``SystemExit("--set takes PROP=VALUE, ...")``)."""
    return isinstance(error, USER_ERRORS) or (
        isinstance(error, SystemExit) and isinstance(error.code, str)
    )


def _code(error: BaseException) -> int:
    return Exit.REFUSED if isinstance(error, SystemExit) else exit_code(error)


if __name__ == "__main__":
    sys.exit(main())
