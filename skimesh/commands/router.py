"""``skimesh router``: a Zenoh router from the Python wheel (any ``zenohd`` works the same)."""

from __future__ import annotations

import argparse
import functools
import logging
import sys
from pathlib import Path

import anyio

from meshlink import DEFAULT_ROUTER_ENDPOINT, run_router

from ..runtime import run_service

__all__ = ["add_parser"]


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "router",
        help="run a Zenoh router (one per site; agents and tools connect to it)",
        description="Run a Zenoh router. Agents, the world model and the CLI connect to it "
        "in client mode. Listen on a routable address to accept other hosts.",
    )
    p.add_argument(
        "--listen",
        action="append",
        metavar="ENDPOINT",
        help=f"endpoint to listen on, repeatable (default {DEFAULT_ROUTER_ENDPOINT}); "
        "e.g. tcp/0.0.0.0:7447 to accept other hosts",
    )
    p.add_argument("--config", metavar="FILE", help="Zenoh JSON5 config (TLS, auth, ACL...)")
    p.set_defaults(func=_run)


def _run(args: argparse.Namespace) -> int:
    # --listen wins; else the config file's listen endpoints; else the loopback default.
    listen = list(args.listen or ([] if args.config else [DEFAULT_ROUTER_ENDPOINT]))
    if args.config and not Path(args.config).is_file():
        print(f"skimesh router: no config file {args.config}", file=sys.stderr)
        return 2

    async def main() -> int:
        where = ", ".join(listen) or f"the endpoints of {args.config}"
        async with anyio.create_task_group() as tg:  # errors: printed by skimesh.cli.main
            await tg.start(functools.partial(run_router, listen, config_file=args.config))
            logging.getLogger("skimesh").warning("router listening on %s", where)
        return 0

    return run_service(main)
