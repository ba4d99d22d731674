"""The ``skimesh`` command: one entry point for every service and tool.

Run ``skimesh --help`` for the list; every sub-command has its own ``--help``.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from importlib import metadata

from device_drivers import DeviceError
from meshlink import MeshlinkError
from skill_agent import SkillError
from task_agent import TaskError
from wm_store import WmError

from .commands import agent, demo, events, router, sim, site, task, wm
from .errors import SkimeshError
from .runtime import configure_logging

__all__ = ["build_parser", "describe_error", "main"]


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="skimesh",
        description="skimesh: a Zenoh-distributed multi-robot skill mesh. Start with "
        "`skimesh demo`; run services on several hosts with `router`, `wm`, ... and "
        "`--connect tcp/HOST:7447`.",
    )
    parser.add_argument(
        "-v", "--verbose", action="count", default=0, help="more log output (-vv: debug)"
    )
    parser.add_argument(
        "--version", action="version", version=f"skimesh {_version()}", help="print the version"
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    router.add_parser(sub)
    wm.add_parser(sub)
    agent.add_parser(sub)
    demo.add_parser(sub)
    sim.add_parser(sub)
    task.add_parser(sub)
    events.add_parser(sub)
    site.add_parser(sub)
    return parser


def _version() -> str:
    try:
        return metadata.version("skimesh")
    except metadata.PackageNotFoundError:  # a source tree that was never installed
        return "unknown (not installed)"


#: Errors a user can act on: printed as one line (exit code 2), not as a traceback.
USER_ERRORS: tuple[type[Exception], ...] = (
    MeshlinkError,
    WmError,
    SkillError,
    TaskError,
    DeviceError,
    SkimeshError,
    OSError,
)


def describe_error(error: BaseException) -> str:
    """One line for a user: the message, or the kind of error where it has none (a bare
    ``TimeoutError`` says nothing by itself)."""
    text = str(error)
    if isinstance(error, TimeoutError) and not text:
        return "timed out (no answer in time; is the router reachable and the service running?)"
    return text or type(error).__name__


def _leaves(error: BaseException) -> list[BaseException]:
    if isinstance(error, BaseExceptionGroup):
        return [leaf for e in error.exceptions for leaf in _leaves(e)]
    return [error]


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    configure_logging(args.verbose)
    try:
        return int(args.func(args))
    except KeyboardInterrupt:
        return 130
    except (*USER_ERRORS, BaseExceptionGroup) as error:  # type: ignore[misc]  # a tuple: mypy misreads the unpacking
        leaves = _leaves(error)
        if not all(isinstance(leaf, USER_ERRORS) for leaf in leaves):
            raise
        for leaf in leaves:
            print(f"skimesh {args.command}: {describe_error(leaf)}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
