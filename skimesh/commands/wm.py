"""``skimesh wm``: run the world-model store, or read and write it.

``skimesh wm --data DIR`` serves the store (``--scenario S``: with S's initial scene, loaded
once). With a sub-command (``ls``, ``get``, ``tree``, ``query``, ``sparql``, ``export``,
``import``, ``import-scenario``, ``info``) it is a client of a running store.
"""

from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Awaitable, Callable
from pathlib import Path
from typing import TYPE_CHECKING

import anyio
import msgspec

from meshlink import add_mesh_arguments, mesh_config_from_args, open_mesh
from wm_store import (
    Element,
    Ontology,
    PropertyFilter,
    Query,
    StoreConfig,
    WmClient,
    WmStore,
    export_turtle,
    import_turtle,
    serve_store,
)
from wm_store.ontology import core_ontology_path
from wm_store.protocol import Transact

from ..connect import wm_session
from ..render import element_line, render_tree
from ..runtime import run_service

if TYPE_CHECKING:
    from device_drivers.scenario import Scenario

__all__ = ["add_parser", "load_ontology"]

_log = logging.getLogger("skimesh.wm")
Body = Callable[[WmClient], Awaitable[int]]


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "wm",
        help="run the world-model store, or read/write it (ls, get, tree, query, ...)",
        description="Without a sub-command: serve the world model (durable in --data). "
        "With one: talk to a running store.",
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
    p.add_argument("--ontology", action="append", metavar="TTL", help="extra ontology file(s)")
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

    ls = cmds.add_parser("ls", help="list elements (optionally of a type, with subclasses)")
    ls.add_argument("type", nargs="?", default="")
    ls.add_argument("--json", action="store_true", help="machine-readable output")
    ls.set_defaults(
        func=lambda a: _client(a, lambda wm: _print_found(a, wm.resolve_element(type=a.type)))
    )

    get = cmds.add_parser("get", help="show elements by id, as JSON")
    get.add_argument("ids", nargs="+")
    get.set_defaults(
        func=lambda a: _client(a, lambda wm: _print_json([wm.get_element(i) for i in a.ids]))
    )

    tree = cmds.add_parser("tree", help="print the spatial scene tree")
    tree.add_argument("root", nargs="?", help="start from this element")
    tree.set_defaults(func=lambda a: _client(a, lambda wm: _print_tree(wm, a.root)))

    query = cmds.add_parser("query", help="resolve elements: TYPE [--label L] [--where prop=value]")
    query.add_argument("type", nargs="?", default="")
    query.add_argument("--label", default="")
    query.add_argument("--where", action="append", default=[], metavar="PROP=VALUE")
    query.add_argument("--json", action="store_true")
    query.set_defaults(func=_query)

    sparql = cmds.add_parser("sparql", help="run a read-only SPARQL query over ontology + scene")
    sparql.add_argument("query", help="the query text, or @FILE")
    sparql.set_defaults(func=_sparql)

    export = cmds.add_parser("export", help="write the scene as Turtle (stdout or FILE)")
    export.add_argument("file", nargs="?")
    export.set_defaults(func=_export)

    imp = cmds.add_parser("import", help="add the individuals of a Turtle scene file")
    imp.add_argument("file")
    imp.set_defaults(func=_import)

    scen = cmds.add_parser(
        "import-scenario", help="load a scenario's initial scene (once: not if it is there)"
    )
    scen.add_argument("name", metavar="SCENARIO", help="a scenario name (kitting, ...) or file")
    scen.set_defaults(func=_import_scenario)

    info = cmds.add_parser("info", help="store revision, size, durability")
    info.set_defaults(func=lambda a: _client(a, _info))


def load_ontology(extra: list[str] | None) -> Ontology:
    """The core ontology, plus any extra Turtle files given on the command line."""
    if not extra:
        return Ontology.default()
    return Ontology.load(core_ontology_path(), *(Path(f) for f in extra))


def _serve(args: argparse.Namespace) -> int:
    if args.wm_command:  # a sub-command without its own func cannot happen; keep argparse honest
        raise SystemExit(f"unknown wm command {args.wm_command}")
    config = StoreConfig(data_dir=args.data, durability=args.durability)
    ontology = load_ontology(args.ontology)
    scene = Path(args.scene).read_text() if args.scene else None
    scenario = _read_scenario(args.scenario) if args.scenario else None
    mesh_config = mesh_config_from_args(args)

    async def main() -> int:
        store = await WmStore.open(ontology, config)
        if store.recovery_detail:
            _log.warning("recovery: %s", store.recovery_detail)
        async with open_mesh(mesh_config) as mesh, anyio.create_task_group() as tg:
            await tg.start(serve_store, mesh, store)
            if scene is not None and not store.state.elements:
                ops = import_turtle(scene, store.ontology, state=store.state)
                await store.transact(Transact(ops=ops, author="scene-import"))
            if scenario is not None:
                await _load_scenario(store, scenario)
            _log.warning(
                "world model ready: revision %d, %d elements on mesh %r",
                store.revision,
                len(store.state.elements),
                mesh_config.mesh,
            )
        return 0

    return run_service(main)


def _client(args: argparse.Namespace, body: Body) -> int:
    async def main() -> int:
        async with wm_session(args) as wm:
            return await body(wm)

    return run_service(main)


async def _print_found(args: argparse.Namespace, found: list[Element]) -> int:
    if args.json:
        sys.stdout.write(msgspec.json.encode(found).decode() + "\n")
    else:
        for element in found:
            print(element_line(element))
    return 0 if found else 1


async def _print_json(obj: object) -> int:
    sys.stdout.write(msgspec.json.format(msgspec.json.encode(obj)).decode() + "\n")
    return 0


async def _print_tree(wm: WmClient, root: str | None) -> int:
    if root:
        wm.get_element(root)
    print(render_tree(wm.replica.state, [root] if root else None))
    return 0


def _query(args: argparse.Namespace) -> int:
    filters = []
    for cond in args.where:
        name, sep, raw = cond.partition("=")
        if not sep:
            raise SystemExit(f"--where takes PROP=VALUE, not {cond!r}")
        filters.append(PropertyFilter(property=name, op="eq", value=_parse_scalar(raw)))
    q = Query(type=args.type, label=args.label, filters=filters)
    return _client(args, lambda wm: _print_found(args, list(wm.resolve_element(q))))


def _parse_scalar(raw: str) -> bool | int | float | str:
    if raw in ("true", "false"):
        return raw == "true"
    for convert in (int, float):
        try:
            return convert(raw)
        except ValueError:
            pass
    return raw


def _sparql(args: argparse.Namespace) -> int:
    text = Path(args.query[1:]).read_text() if args.query.startswith("@") else args.query

    async def body(wm: WmClient) -> int:
        reply = await wm.sparql(text)
        print("\t".join(reply.variables))
        for row in reply.rows:
            print("\t".join("" if v is None else v for v in row))
        return 0

    return _client(args, body)


def _export(args: argparse.Namespace) -> int:
    out: list[str] = []

    async def body(wm: WmClient) -> int:
        out.append(export_turtle(wm.replica.state, wm.ontology))
        return 0

    code = _client(args, body)
    if args.file:
        Path(args.file).write_text(out[0])
    else:
        sys.stdout.write(out[0])
    return code


def _import(args: argparse.Namespace) -> int:
    text = Path(args.file).read_text()

    async def body(wm: WmClient) -> int:
        reply = await wm.transact(import_turtle(text, wm.ontology, state=wm.replica.state))
        added = sum(1 for k in reply.ids if not k.startswith("#"))
        print(f"imported {added} elements at revision {reply.revision}")
        return 0

    return _client(args, body)


def _read_scenario(name: str) -> Scenario:
    from ..scenario_scene import read_scenario

    return read_scenario(name)


async def _load_scenario(store: WmStore, scenario: Scenario) -> None:
    """``--scenario``: load the scenario's scene into the store, unless it is there already."""
    from ..scenario_scene import scene_loaded, scene_ops

    ops = scene_ops(scenario, store.state, store.ontology)
    if not ops:
        there = ", ".join(scene_loaded(scenario, store.state)[:3])
        _log.warning("scenario %r: its scene is in the store already (%s)", scenario.name, there)
        return
    reply = await store.transact(Transact(ops=ops, author="scenario-import"))
    _log.warning("scenario %r: scene loaded at revision %d", scenario.name, reply.revision)


def _import_scenario(args: argparse.Namespace) -> int:
    from ..scenario_scene import scene_loaded, scene_ops

    scenario = _read_scenario(args.name)

    async def body(wm: WmClient) -> int:
        ops = scene_ops(scenario, wm.replica.state, wm.ontology)
        if not ops:
            there = ", ".join(scene_loaded(scenario, wm.replica.state)[:3])
            print(f"scenario {scenario.name!r} is in the world model already ({there}): "
                  "nothing imported")  # fmt: skip
            return 0
        reply = await wm.transact(ops)
        added = sum(1 for k in reply.ids if k.startswith("$"))
        print(f"scenario {scenario.name!r}: {added} elements at revision {reply.revision}")
        return 0

    return _client(args, body)


async def _info(wm: WmClient) -> int:
    return await _print_json(await wm.info())
