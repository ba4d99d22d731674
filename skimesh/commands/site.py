"""``skimesh up SITE.toml``, ``skimesh down SITE.toml``, ``skimesh status SITE.toml``: run
one host's part of a site (:mod:`skimesh.site`), stop it from another terminal, show it.

Exit codes: ``up`` 0 after a clean stop, 1 when the site did not come up, 2 for a site file
that cannot run; ``down`` 0 once everything stopped (or nothing ran), 1 when the supervisor
did not stop in time; ``status`` 0 when the site is up here (with ``--probe``: every
component answers), 1 otherwise.
"""

from __future__ import annotations

import argparse
import os
import signal
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from ..site import Plan, StateDir

__all__ = ["add_parser"]

Sub = argparse._SubParsersAction  # argparse keeps the sub-parsers action class private


def add_parser(sub: Sub[argparse.ArgumentParser]) -> None:
    """Add ``up``, ``down`` and ``status``."""
    up = sub.add_parser(
        "up",
        help="bring up this host's part of a site (SITE.toml): health checks, restarts, logs",
        description="Start this host's processes of a site in dependency order (routers, "
        "store, simulator, agents, task agent), each ready (a health probe) before the next; "
        "wait over the mesh for the components of other hosts; restart a process that ends "
        "by the site's restart policy; log each process to STATE_DIR/logs/NAME.log; show "
        "their status; stop them all in reverse order on Ctrl-C, SIGTERM or `skimesh down`.",
    )
    _site_arguments(up)
    up.add_argument("--status", action="store_true", help="print the status and exit")
    up.set_defaults(func=_up)
    down = sub.add_parser("down", help="stop the site `skimesh up` runs on this host")
    _site_arguments(down)
    down.set_defaults(func=_down)
    status = sub.add_parser("status", help="the state of each component of a site")
    _site_arguments(status)
    status.add_argument(
        "--probe",
        action="store_true",
        help="also probe every component, of every host, over the mesh (router endpoint: "
        "this host's)",
    )
    status.set_defaults(func=_status)


def _site_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("site", metavar="SITE.toml", type=Path, help="the site file")
    p.add_argument(
        "--host", help="the site's host this machine is (default: its hostname, or the only host)"
    )
    p.add_argument(
        "--state-dir",
        type=Path,
        metavar="DIR",
        help="logs, status, lock and the store's data (default: the site's state_dir, else "
        "$XDG_STATE_HOME/skimesh/sites/SITE-HOST, ~/.local/state/...)",
    )
    p.add_argument(
        "--listen",
        action="append",
        metavar="ENDPOINT",
        help="replace the listen endpoints of the site's only router (a rehearsal on another "
        "port); give the same to up, down and status",
    )


def _plan(args: argparse.Namespace) -> tuple[Plan, StateDir]:
    from ..site import StateDir, default_state_dir, load_site, make_plan

    plan = make_plan(load_site(args.site), args.site, args.host, listen=args.listen)
    where = args.state_dir or default_state_dir(args.site, plan.host, plan.site.state_dir)
    return plan, StateDir(where)


def _up(args: argparse.Namespace) -> int:
    if args.status:
        args.probe = False
        return _status(args)
    import anyio

    from ..site import LineView, LiveView, Supervisor

    plan, state = _plan(args)
    if plan.security is not None:
        from ..site import ensure_credentials

        folder = ensure_credentials(plan)
        print(
            f"skimesh up: a secure site (TLS, a certificate per component, least-privilege "
            f"ACL); credentials in {folder}; to use the CLI: --config {folder}/operator.json5",
            file=sys.stderr,
        )
    state.acquire()
    try:
        if sys.stderr.isatty():
            with LiveView() as live:
                supervisor = Supervisor(plan, state, live)
                supervisor.open_logs()
                code = anyio.run(supervisor.run)
        else:
            supervisor = Supervisor(plan, state, LineView())
            supervisor.open_logs()
            code = anyio.run(supervisor.run)
    finally:
        state.release()
    if supervisor.message:
        print(f"skimesh up: {supervisor.message}", file=sys.stderr)
    return code


def _down(args: argparse.Namespace) -> int:
    from ..site import row_line

    plan, state = _plan(args)
    holder = state.holder()
    if holder is None:
        left = _stop_orphans(state, plan.site.stop_grace)
        print(f"skimesh down: the site is not up on host {plan.host}{left}", file=sys.stderr)
        return 0
    os.kill(holder, signal.SIGTERM)
    wait = plan.site.stop_grace * (len(plan.local()) + 1) + 10.0
    deadline = time.monotonic() + wait
    while state.holder() is not None:
        if time.monotonic() > deadline:
            print(f"skimesh down: `skimesh up` (pid {holder}) still runs after {wait:g} s")
            return 1
        time.sleep(0.1)
    status = state.read_status()
    for row in status.rows if status else []:
        if row.host == plan.host:
            print(row_line(row))
    return 0


def _stop_orphans(state: StateDir, grace: float) -> str:
    stopped = state.stop_leftovers(grace)
    return f"; stopped what it left running: {', '.join(stopped)}" if stopped else ""


def _status(args: argparse.Namespace) -> int:
    from rich.console import Console

    from ..site import table

    plan, state = _plan(args)
    holder = state.holder()
    status = state.read_status()
    code = 0
    if holder is None:
        print(f"the site is not up on host {plan.host} (state: {state.path})")
        code = 1
    elif status is not None:
        print(f"skimesh up (pid {holder}) on host {plan.host}; logs in {state.logs}")
        Console(soft_wrap=True).print(table(status.rows))
    if args.probe:
        import anyio

        answers = anyio.run(_probe_all, plan)
        for name, why in answers:
            print(f"{name}: {why or 'ready'}")
        code = 1 if any(why and not why.startswith("skipped") for _, why in answers) else code
    return code


async def _probe_all(plan: Plan) -> list[tuple[str, str]]:
    from meshlink import MeshConfig, MeshlinkError, open_mesh

    from ..site import probe

    config = MeshConfig(connect=plan.connect, mesh=plan.site.mesh, config_file=plan.probe_config)
    try:
        async with open_mesh(config) as mesh:
            return [(c.name, await probe(c, mesh)) for c in plan.components]
    except MeshlinkError as e:
        print(f"skimesh status: no mesh session: {e}", file=sys.stderr)
        return [(c.name, "not probed: no mesh session") for c in plan.components]
