"""The client sub-commands of ``skimesh wm``: read and write a running world-model store.

Each joins the mesh, loads a replica of the world model, answers from it (or asks the store)
and exits: ``ls``, ``get``, ``tree``, ``query``, ``sparql``, ``check``, ``export``, ``info``
read; ``import`` and ``import-scenario`` write, each in one transaction. Most take ``--json``
for machine-readable output; every one explains itself with ``--help``.
"""

from __future__ import annotations

import argparse
import functools
import hashlib
import sys
from collections.abc import Awaitable, Callable
from pathlib import Path

import anyio
import msgspec

from meshlink import add_mesh_arguments
from wm_store import (
    WmClient,
    transact_in_batches,
)
from wm_store.protocol import (
    Element,
    PropertyFilter,
    Query,
)
from wm_store.scene import SceneState, id_sort_key

from ..errors import UsageError
from ..runtime import run_service
from ._connect import mesh_session, wm_session
from ._edit import add_edit_commands
from ._render import element_line, render_tree
from ._store_reads import element_ids, elements_by_name
from ._teach import add_ontology_commands

__all__ = ["add_client_commands"]

Body = Callable[[WmClient], Awaitable[int]]


def add_client_commands(cmds: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the client sub-commands to ``skimesh wm``'s sub-parsers."""
    _add_read_commands(cmds)
    _add_write_commands(cmds)
    add_ontology_commands(cmds)
    add_edit_commands(cmds)
    for sub in cmds.choices.values():  # the connection options also after the sub-command
        add_mesh_arguments(sub, repeat=True)
        sub.add_argument(
            "--timeout",
            type=float,
            default=argparse.SUPPRESS,
            metavar="S",
            help="request timeout in seconds (default: 5)",
        )


_JSON_HELP = "machine-readable output: one JSON value on stdout"


def _command(
    cmds: argparse._SubParsersAction[argparse.ArgumentParser],
    name: str,
    summary: str,
    details: str,
    *,
    json_help: str | None = _JSON_HELP,
) -> argparse.ArgumentParser:
    """A client sub-command: ``summary`` in the list, ``summary`` + ``details`` in its --help."""
    description = f"{summary[0].upper()}{summary[1:]}. {details}"
    sub = cmds.add_parser(name, help=summary, description=description)
    if json_help is not None:
        sub.add_argument("--json", action="store_true", help=json_help)
    return sub


def _add_read_commands(cmds: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    ls = _command(
        cmds,
        "ls",
        "list elements, optionally of one class",
        "One line per element: id, label, class, key properties. A class includes its "
        "subclasses (`ls Part` lists gears and shafts). Exit code 1 if nothing matches.",
        json_help="print the elements as a JSON list (every field)",
    )
    ls.add_argument("type", nargs="?", default="", help="a class, e.g. Part (default: all)")
    ls.set_defaults(
        func=lambda a: _client(a, lambda wm: _print_found(a, wm.resolve_element(type=a.type)))
    )

    get = _command(
        cmds,
        "get",
        "show elements by id or label, as JSON",
        "Prints a JSON list with every field of each element (type, label, properties, "
        "observations, revision). A label stands for the one element it names; fails naming "
        "any name the world model does not have, and the elements a shared label names.",
        json_help=None,
    )
    get.add_argument(
        "ids", nargs="+", metavar="ID", help="element id (Gear-1) or a label only it has (r1-arm)"
    )
    get.set_defaults(func=_get)

    tree = _command(
        cmds,
        "tree",
        "print the spatial scene tree",
        "Who contains or has whom (contain, hasA, ...), indented, from every element with no "
        "spatial parent (or from ROOT).",
        json_help="print the tree as nested objects {id, type, label, relation, children}",
    )
    tree.add_argument(
        "root",
        nargs="?",
        metavar="ROOT",
        help="start from this element (an id, or a label only it has)",
    )
    tree.set_defaults(func=lambda a: _client(a, lambda wm: _print_tree(a, wm)))

    query = _command(
        cmds,
        "query",
        "find elements by class, label and property values",
        "Example: `query Gear --where mass=0.12`. A class includes its subclasses; each "
        "--where must hold. Exit code 1 if nothing matches.",
        json_help="print the elements as a JSON list (every field)",
    )
    query.add_argument("type", nargs="?", default="", help="a class, e.g. Part (default: any)")
    query.add_argument("--label", default="", help="only elements with exactly this label")
    query.add_argument(
        "--where",
        action="append",
        default=[],
        metavar="PROP=VALUE",
        help="property equals value (true/false, numbers, else text); repeatable",
    )
    query.set_defaults(func=_query)

    sparql = _command(
        cmds,
        "sparql",
        "run a read-only SPARQL query over ontology + scene",
        "Prefixes skm: (ontology), skms: (scene elements), rdf:, rdfs:, owl: and xsd: are "
        "predeclared. Prints a tab-separated table with a header row; elements appear as "
        "their ids (Gear-1), ontology terms as skm:Name. Example: "
        "'SELECT ?e WHERE { ?e a skm:Gear }'. Slow on big scenes (the store builds an RDF "
        "graph): prefer query or ls where they can answer.",
        json_help="print {revision, variables, rows}, each row an object {variable: value}",
    )
    sparql.add_argument("query", help="the query text, or @FILE to read it from a file")
    sparql.set_defaults(func=_sparql)

    check = _command(
        cmds,
        "check",
        "report elements that miss relations their class requires",
        "The ontology's minimum cardinalities (e.g. a MobileManipulator has at least one "
        "Arm) cannot be enforced on each write (a robot is added before its arm), so the "
        "store reports them here. Maximums are refused on write and never show up. Exit "
        "code 0 if every minimum is met, 1 if not.",
        json_help="print {revision, checked, violations}, each violation {element, type, "
        "relation, required, present, on_class, declared_on, message}",
    )
    check.add_argument("ids", nargs="*", metavar="ID", help="check only these (default: all)")
    check.set_defaults(func=_check)

    export = _command(
        cmds,
        "export",
        "write the scene as Turtle (to stdout or FILE)",
        "The individuals of the scene with their properties and relations, readable in "
        "Protégé and by `wm import` / `wm --scene` (ids are kept).",
        json_help="print {revision, elements, relations, bytes, file}; without FILE the "
        "Turtle is in the field turtle",
    )
    export.add_argument("file", nargs="?", metavar="FILE", help="write here instead of stdout")
    export.set_defaults(func=_export)

    info = _command(
        cmds,
        "info",
        "show the store's revision, size and durability, as JSON",
        "Also the oldest revision it can still replay changes from, its data directory and "
        "start time.",
        json_help=None,
    )
    info.set_defaults(func=lambda a: _client(a, _info))


def _add_write_commands(cmds: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    imp = _command(
        cmds,
        "import",
        "add the ontology terms and individuals of a Turtle file",
        "The terms the file declares are taught first, then its individuals are added, in "
        "transactions of --batch ops (a file of any size imports; progress on stderr). Each "
        "batch commits on its own: if one is refused, the ones before it stay, and running the "
        "same import again goes on from there (batches are sent under ids made from the file's "
        "digest). Individuals named <Class>-<n> keep that id (it must be new to the store); "
        "others get fresh ids, printed with --json.",
        json_help="print {revision, elements, ids}: ids maps each individual's name to its id",
    )
    imp.add_argument("file", metavar="FILE", help="a Turtle file, e.g. configs/scenes/sample.ttl")
    imp.add_argument(
        "--batch",
        type=int,
        default=5000,
        metavar="N",
        help="ops per transaction (default: %(default)s; the store takes up to 10,000)",
    )
    imp.set_defaults(func=_import)

    scen = _command(
        cmds,
        "import-scenario",
        "load a scenario's initial scene (once: not if it is there)",
        "Adds the stations, parts and robots of a scenario in one transaction, unless the "
        "world model holds them already.",
        json_help=None,
    )
    scen.add_argument("name", metavar="SCENARIO", help="a scenario name (kitting, ...) or file")
    scen.set_defaults(func=_import_scenario)


def _element(wm: WmClient, name: str) -> Element:
    """The element ``name`` gives (an id or a label only it has), or ElementNotFoundError
    naming the closest ids and labels."""
    return wm.get_element(element_ids([name], wm.replica.state.elements.values())[0])


def _get(args: argparse.Namespace) -> int:
    """``wm get``: reads from the store, no replica (:func:`elements_by_name`)."""

    async def main() -> int:
        async with mesh_session(args) as mesh:
            found = await elements_by_name(mesh, args.ids, timeout=args.timeout)
        return await _print_json(found)

    return run_service(main)


def _client(args: argparse.Namespace, body: Body) -> int:
    async def main() -> int:
        async with wm_session(args) as wm:
            return await body(wm)

    return run_service(main)


async def _print_found(args: argparse.Namespace, found: list[Element]) -> int:
    if args.json:
        await _write_json(found)
    else:
        for element in found:
            print(element_line(element))
    return 0 if found else 1


async def _print_json(obj: object) -> int:
    sys.stdout.write(msgspec.json.format(msgspec.json.encode(obj)).decode() + "\n")
    return 0


async def _print_tree(args: argparse.Namespace, wm: WmClient) -> int:
    state = wm.replica.state
    roots = [_element(wm, args.root).id] if args.root else None
    if args.json:
        return await _write_json(_tree_json(state, roots))
    print(render_tree(state, roots))
    return 0


def _tree_json(state: SceneState, roots: list[str] | None) -> list[dict[str, object]]:
    """The spatial tree as nested objects; roots as :func:`._render.render_tree`'s."""
    if roots is None:
        roots = sorted((i for i in state.elements if state.parent(i) is None), key=id_sort_key)

    def node(element_id: str, relation: str | None) -> dict[str, object]:
        e = state.elements[element_id]
        return {"id": e.id, "type": e.type, "label": e.label, "relation": relation}

    top = [node(root, None) for root in roots]
    stack = list(top)
    while stack:  # iterative: a deep tree cannot overflow the stack
        parent = stack.pop()
        children = [node(r.object, r.predicate) for r in state.spatial_children(str(parent["id"]))]
        parent["children"] = children
        stack.extend(children)
    return top


async def _write_json(obj: object) -> int:
    sys.stdout.write(msgspec.json.encode(obj).decode() + "\n")
    return 0


def _query(args: argparse.Namespace) -> int:
    filters = []
    for cond in args.where:
        name, sep, raw = cond.partition("=")
        if not sep:
            raise UsageError(f"--where takes PROP=VALUE, not {cond!r}")
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
        if args.json:
            rows = [dict(zip(reply.variables, row, strict=True)) for row in reply.rows]
            return await _write_json(
                {"revision": reply.revision, "variables": reply.variables, "rows": rows}
            )
        print("\t".join(reply.variables))
        for row in reply.rows:
            print("\t".join("" if v is None else v for v in row))
        return 0

    return _client(args, body)


def _check(args: argparse.Namespace) -> int:
    async def body(wm: WmClient) -> int:
        reply = await wm.check_cardinality(args.ids)
        code = 1 if reply.violations else 0
        if args.json:
            found = {"revision": reply.revision, "checked": reply.checked}
            await _write_json({**found, "violations": reply.violations})
            return code
        for violation in reply.violations:
            print(violation.message)
        outcome = f"{len(reply.violations)} unmet" if code else "every one met"
        print(
            f"minimum cardinalities of {reply.checked} element(s) at revision "
            f"{reply.revision}: {outcome}"
        )
        return code

    return _client(args, body)


def _export(args: argparse.Namespace) -> int:
    async def body(wm: WmClient) -> int:
        state = wm.replica.state.copy()  # the replica keeps changing; rdflib runs in a thread
        from wm_store.rdf import export_turtle  # rdflib, only to export

        text = await anyio.to_thread.run_sync(export_turtle, state, wm.ontology)
        if args.file:
            await anyio.Path(args.file).write_text(text)
        elif not args.json:
            sys.stdout.write(text)
        if args.json:
            summary: dict[str, object] = {
                "revision": state.revision,
                "elements": len(state.elements),
                "relations": state.relation_count,
                "bytes": len(text.encode()),
                "file": args.file,
            }
            if not args.file:
                summary["turtle"] = text
            await _write_json(summary)
        return 0

    return _client(args, body)


def _import(args: argparse.Namespace) -> int:
    text = Path(args.file).read_text()

    async def body(wm: WmClient) -> int:
        from wm_store.rdf import import_turtle  # rdflib, only to import

        state = wm.replica.state.copy()  # for the id counters; rdflib parses in a thread
        ops = await anyio.to_thread.run_sync(
            functools.partial(import_turtle, text, wm.ontology, state=state)
        )
        if not ops:
            print(f"{args.file}: no individuals or terms to import", file=sys.stderr)
            return 1
        batches = -(-len(ops) // max(1, args.batch))

        def progress(done: int, total: int, revision: int) -> None:
            if batches > 1:
                print(f"  {done}/{total} ops at revision {revision}", file=sys.stderr)

        digest = hashlib.sha256(text.encode()).hexdigest()[:16]
        ids = await transact_in_batches(
            wm, ops, size=max(1, args.batch), txn_prefix=f"import-{digest}", progress=progress
        )
        if args.json:
            return await _write_json({"revision": wm.revision, "elements": len(ids), "ids": ids})
        print(f"imported {len(ids)} elements at revision {wm.revision}")
        return 0

    return _client(args, body)


def _import_scenario(args: argparse.Namespace) -> int:
    from scenario.wm import scenario_terms, scene_loaded, scene_ops
    from skimesh.paths import read_scenario

    scenario = read_scenario(args.name)
    terms = scenario_terms(scenario)

    async def body(wm: WmClient) -> int:
        ops = scene_ops(scenario, wm.replica.state, wm.ontology, terms=terms)
        if scene_loaded(scenario, wm.replica.state):
            if ops:  # its ontology terms, in case the files gained some since
                await wm.transact(ops)
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
