"""``skimesh router``: a Zenoh router from the Python wheel (any ``zenohd`` works the same).

It takes the Zenoh flags of every other command (``--connect``, ``--listen``, ``--config``;
:func:`meshlink.add_mesh_arguments`). ``--connect`` links it to other routers: on several
hosts, one router per host, each connected to the others, and every process a client of its
own host's router.
"""

from __future__ import annotations

import argparse
import functools
import logging
import sys
from pathlib import Path

import anyio

from meshlink import DEFAULT_ROUTER_ENDPOINT, SessionError, add_mesh_arguments, run_router

from ..errors import Exit, UsageError
from ..runtime import run_service

__all__ = ["add_parser"]


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "router",
        help="run a Zenoh router (one per site or host; agents and tools connect to it)",
        description="Run a Zenoh router. Agents, the world model and the CLI connect to it "
        "in client mode. Listen on a routable address to accept other hosts; --connect to "
        "link it to the routers of other hosts.",
    )
    add_mesh_arguments(p, router=True)
    p.set_defaults(func=_run)


def _run(args: argparse.Namespace) -> int:
    # --listen wins; else the config file's listen endpoints; else the loopback default
    # (meshlink.router_config). --connect likewise replaces the file's connect endpoints.
    listen: list[str] = args.listen or []
    connect: list[str] = args.connect or []
    config_file: str | None = args.zenoh_config
    if config_file and not Path(config_file).is_file():
        print(f"skimesh router: no config file {config_file}", file=sys.stderr)
        return Exit.REFUSED

    async def main() -> int:
        run = functools.partial(run_router, listen, connect=connect, config_file=config_file)
        async with anyio.create_task_group() as tg:  # errors: printed by skimesh.cli.main
            try:
                await tg.start(run)
            except SessionError as e:  # a busy or bad listen endpoint: exit 2, not "unreachable"
                raise UsageError(str(e)) from None
            where = ", ".join(listen) or (
                f"the endpoints of {config_file}" if config_file else DEFAULT_ROUTER_ENDPOINT
            )
            # Zenoh keeps retrying a router's connect endpoints: the others may start later
            linked = f", connecting to {', '.join(connect)}" if connect else ""
            logging.getLogger("skimesh.router").info("router listening on %s%s", where, linked)
        return 0

    return run_service(main)
