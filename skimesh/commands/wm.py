"""``skimesh wm``: run the world-model store, or read and write it.

``skimesh wm --data DIR`` serves the store (``--scenario S``: with S's initial scene, loaded
once). With a sub-command (``ls``, ``get``, ``tree``, ``query``, ``sparql``, ``check``,
``export``, ``import``, ``import-scenario``, ``info``; in :mod:`._wm_client`) it is a client of
a running store.
"""

from __future__ import annotations

import argparse
import logging
from pathlib import Path
from typing import TYPE_CHECKING

import anyio

from meshlink import add_mesh_arguments, mesh_config_from_args
from wm_store.protocol import Transact

from ..errors import UsageError
from ..runtime import run_service
from ._connect import read_terms, service_mesh
from ._wm_client import add_client_commands

if TYPE_CHECKING:
    from scenario import Scenario
    from wm_store.server import WmStore

__all__ = ["add_parser"]

_log = logging.getLogger("skimesh.wm")


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "wm",
        help="run the world-model store, or read/write it (ls, get, tree, query, ...)",
        description="Without a sub-command: serve the world model (durable in --data). "
        "With one: talk to a running store, e.g. `skimesh wm --connect tcp/ROUTER:7447 tree`; "
        "`skimesh wm COMMAND --help` explains each command. Most take --json.",
    )
    add_mesh_arguments(p)
    p.add_argument("--timeout", type=float, default=5.0, help="request timeout in seconds")
    p.add_argument(
        "--data", metavar="DIR", help="data directory (log + snapshots); default: memory"
    )
    p.add_argument(
        "--durability",
        choices=("group", "fsync", "none"),
        default="group",
        help="group: group commit (default); fsync: one fsync per transaction; none: no fsync",
    )
    p.add_argument(
        "--sparql-timeout",
        type=float,
        default=10.0,
        metavar="S",
        help="serving: end a SPARQL query (run in a worker process) after S seconds "
        "(default: %(default)s)",
    )
    p.add_argument(
        "--ontology",
        action="append",
        default=[],
        metavar="TTL",
        help="serving: teach the store the terms of this Turtle file at start (repeatable); "
        "every process of the mesh then has them",
    )
    initial = p.add_mutually_exclusive_group()
    initial.add_argument(
        "--scene", metavar="TTL", help="import this scene at start if the store is empty"
    )
    initial.add_argument(
        "--scenario",
        metavar="NAME",
        help="load this scenario's initial scene at start (a name under configs/scenarios, "
        "e.g. kitting, or a scenario file), unless the store holds it already",
    )
    p.set_defaults(func=_serve)
    cmds = p.add_subparsers(dest="wm_command", metavar="COMMAND")
    add_client_commands(cmds)


def _serve(args: argparse.Namespace) -> int:
    if args.wm_command:  # a sub-command without its own func cannot happen; keep argparse honest
        raise UsageError(f"unknown wm command {args.wm_command}")
    from wm_store.ontology import Ontology  # the store's modules load only to serve
    from wm_store.rdf import import_turtle
    from wm_store.server import StoreConfig, WmStore, serve_store

    config = StoreConfig(
        data_dir=args.data, durability=args.durability, sparql_timeout=args.sparql_timeout
    )
    terms = read_terms(args.ontology)
    scene = Path(args.scene).read_text() if args.scene else None
    scenario = _read_scenario(args.scenario) if args.scenario else None
    mesh_config = mesh_config_from_args(args)

    async def main() -> int:
        store = await WmStore.open(Ontology.default(), config)
        if detail := store.recovery_detail:  # a clean log is news only with -v
            clean = detail.startswith("clean:") and ";" not in detail
            _log.log(logging.INFO if clean else logging.WARNING, "recovery: %s", detail)
        async with (
            service_mesh(mesh_config, "world model") as mesh,
            anyio.create_task_group() as tg,
        ):
            await tg.start(serve_store, mesh, store)
            for name, text in terms:
                before = store.revision
                revision = await store.teach(text, name, author="wm --ontology")
                said = "known already" if revision == before else f"taught at revision {revision}"
                _log.info("ontology %s: %s", name, said)
            if scene is not None and not store.state.elements:
                ops = import_turtle(scene, store.ontology, state=store.state)
                await store.transact(Transact(ops=ops, author="scene-import"))
            if scenario is not None:
                await _load_scenario(store, scenario)
            _log.info(
                "world model ready: revision %d, %d elements on mesh %r",
                store.revision,
                len(store.state.elements),
                mesh_config.mesh,
            )
        return 0

    return run_service(main)


def _read_scenario(name: str) -> Scenario:
    from skimesh.paths import read_scenario

    return read_scenario(name)


async def _load_scenario(store: WmStore, scenario: Scenario) -> None:
    """``--scenario``: load the scenario's scene into the store, unless it is there already."""
    from scenario.wm import scenario_terms, scene_loaded, scene_ops

    terms = await anyio.to_thread.run_sync(scenario_terms, scenario)
    ops = scene_ops(scenario, store.state, store.ontology, terms=terms)
    if there := scene_loaded(scenario, store.state):
        if ops:  # its ontology terms, in case the files gained some since
            await store.transact(Transact(ops=ops, author="scenario-import"))
        shown = ", ".join(there[:3])
        _log.info("scenario %r: its scene is in the store already (%s)", scenario.name, shown)
        return
    reply = await store.transact(Transact(ops=ops, author="scenario-import"))
    _log.info("scenario %r: scene loaded at revision %d", scenario.name, reply.revision)
