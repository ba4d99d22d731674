"""The ontology sub-commands of ``skimesh wm``: show the store's ontology and teach it.

The store is the source of truth for the ontology of the whole mesh: every process takes it
when it connects and follows what is taught later. ``teach`` adds the terms of Turtle files
(classes, relations, data properties, restrictions, templates, as written in Protégé);
``define-class``, ``define-template``, ``define-relation`` and ``define-property`` teach one
term each; ``ontology``
prints the store's ontology (or only what was taught, with where it came from) as Turtle.
Everything taught is persisted, replayed after a restart and exported by ``wm export``.
"""

from __future__ import annotations

import argparse
import sys

import anyio
import msgspec

from wm_store import WmClient
from wm_store.protocol import (
    ClassDefined,
    GetOntology,
    OntologyReply,
    TemplateDef,
    TemplateDefined,
    TermsDefined,
)

from ._connect import read_terms
from ._edit import client as _client
from ._edit import parse_assignments

__all__ = ["add_ontology_commands"]

_KINDS = "float, int, bool, string, Position, Orientation, Pose, Frame, Size, Color"


def add_ontology_commands(cmds: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add ``ontology``, ``teach``, ``define-class``, ``define-relation``, ``define-property``."""
    show = cmds.add_parser(
        "ontology",
        help="print the store's ontology as Turtle (what every process checks against)",
        description="Print the ontology the store serves to the whole mesh, as Turtle: the "
        "core and everything taught since (open it in Protégé). --taught: only what was "
        "taught, each part headed by where it came from.",
    )
    show.add_argument("--taught", action="store_true", help="only what was taught, by source")
    show.add_argument("--json", action="store_true", help="print the taught parts as JSON")
    show.set_defaults(func=lambda a: _client(a, _show))

    teach = cmds.add_parser(
        "teach",
        help="teach the store's ontology the terms of Turtle files",
        description="Add the classes, relations, data properties, restrictions and templates "
        "of each file to the ontology of the whole mesh: checked, persisted, published to "
        "every process. Teaching only adds; terms the ontology has already change nothing.",
    )
    teach.add_argument("files", nargs="+", metavar="TTL", help="Turtle file(s)")
    teach.set_defaults(func=_teach)

    cls = cmds.add_parser(
        "define-class",
        help="teach a new class",
        description="Teach a new class, a subclass of PARENT, e.g. "
        "`skimesh wm define-class Pulley --parent Part`.",
    )
    cls.add_argument("name", help="a capitalised name, e.g. Pulley")
    cls.add_argument("--parent", required=True, help="an existing class, e.g. Part")
    _annotations(cls)
    cls.set_defaults(func=lambda a: _client(a, _define_class))

    tpl = cmds.add_parser(
        "define-template",
        help="teach a default individual (a template) of a class",
        description="Teach a named template with default property values (SkiROS "
        "getDefaultElement), e.g. `skimesh wm define-template big-pulley --type Pulley "
        "--set mass=0.4 --set graspWidth=0.05`. A value is JSON (typed values, lists) or a "
        "number, true/false, or text. A template taught at run time may be taught again to "
        "replace it.",
    )
    tpl.add_argument("name", help="a name of letters, digits, '_' or '-', e.g. big-pulley")
    tpl.add_argument("--type", required=True, metavar="CLASS", help="its class, e.g. Pulley")
    tpl.add_argument(
        "--set", action="append", default=[], metavar="PROP=VALUE", help="a default value"
    )
    tpl.add_argument("--label", default="", help="a readable name")
    tpl.set_defaults(func=lambda a: _client(a, _define_template))

    rel = cmds.add_parser(
        "define-relation",
        help="teach a new relation between classes",
        description="Teach a new relation (an OWL object property), e.g. `skimesh wm "
        "define-relation inspectedBy --domain Part --range Agent`. Give --domain/--range "
        "several times for a union; --parent spatialRelation makes it spatial.",
    )
    rel.add_argument("name", help="a lower-case name, e.g. inspectedBy")
    rel.add_argument("--domain", action="append", default=[], metavar="CLASS",
                     help="class of the subjects (repeat for a union)")  # fmt: skip
    rel.add_argument("--range", action="append", default=[], metavar="CLASS",
                     help="class of the objects (repeat for a union)")  # fmt: skip
    rel.add_argument("--parent", default="", metavar="RELATION", help="a super-relation")
    _annotations(rel)
    rel.set_defaults(func=lambda a: _client(a, _define_relation))

    prop = cmds.add_parser(
        "define-property",
        help="teach a new data property",
        description="Teach a new data property, e.g. `skimesh wm define-property inspected "
        f"--kind bool --domain Part`. Kinds: {_KINDS}.",
    )
    prop.add_argument("name", help="a lower-case name, e.g. inspected")
    prop.add_argument("--kind", required=True, help="the value kind")
    prop.add_argument("--domain", action="append", default=[], metavar="CLASS",
                      help="class of the elements that have it (repeat for a union)")  # fmt: skip
    prop.add_argument("--min", type=float, default=None, help="lowest value (float, int)")
    prop.add_argument("--max", type=float, default=None, help="highest value (float, int)")
    _annotations(prop)
    prop.set_defaults(func=lambda a: _client(a, _define_property))


def _annotations(p: argparse.ArgumentParser) -> None:
    p.add_argument("--label", default="", help="a readable name (rdfs:label)")
    p.add_argument("--comment", default="", help="what it means (rdfs:comment)")


def _source(delta: ClassDefined | TemplateDefined | TermsDefined) -> str:
    match delta:
        case ClassDefined(cls=c):
            return f"class {c.name}"
        case TemplateDefined(template=t):
            return f"template {t.name}"
        case TermsDefined(terms=terms):
            return terms.source or "taught terms"


async def _show(args: argparse.Namespace, wm: WmClient) -> int:
    reply = await wm.request(GetOntology())
    assert isinstance(reply, OntologyReply)
    if args.json:
        parts = [{"source": _source(d), "delta": d} for d in reply.taught]
        sys.stdout.write(msgspec.json.encode(parts).decode() + "\n")
        return 0
    if args.taught:
        for delta in reply.taught:
            print(f"# ---- taught: {_source(delta)}\n{_turtle_of(delta).rstrip()}\n")
        return 0
    whole = await anyio.to_thread.run_sync(_whole_turtle, reply)
    sys.stdout.write(whole)
    return 0


def _turtle_of(delta: ClassDefined | TemplateDefined | TermsDefined) -> str:
    match delta:
        case TermsDefined(terms=terms):
            return terms.turtle
        case ClassDefined(cls=c):
            return f"skm:{c.name} a owl:Class ; rdfs:subClassOf skm:{c.parent} ."
        case TemplateDefined(template=t):
            values = msgspec.json.encode(t.properties).decode()
            return f"# template {t.name}: a {t.type}, {values}"


def _whole_turtle(reply: OntologyReply) -> str:
    from wm_store.ontology import Ontology, replay  # rdflib, only to print the ontology

    onto = replay(Ontology.load(reply.core), reply.taught)
    return onto.graph.serialize(format="turtle")


def _teach(args: argparse.Namespace) -> int:
    files = read_terms(args.files)  # before the loop runs

    async def body(_: argparse.Namespace, wm: WmClient) -> int:
        for name, text in files:
            before = wm.revision
            revision = await wm.teach(text, source=name)
            said = "known already" if revision == before else f"taught at revision {revision}"
            print(f"{name}: {said}")
        return 0

    return _client(args, body)


async def _define_class(args: argparse.Namespace, wm: WmClient) -> int:
    revision = await wm.define_class(args.name, args.parent, label=args.label, comment=args.comment)
    print(f"class {args.name} (a {args.parent}) taught at revision {revision}")
    return 0


async def _define_template(args: argparse.Namespace, wm: WmClient) -> int:
    properties = parse_assignments(args.set)
    template = TemplateDef(name=args.name, type=args.type, label=args.label, properties=properties)
    revision = await wm.define_template(template)
    print(f"template {args.name} (a {args.type}) taught at revision {revision}")
    return 0


async def _define_relation(args: argparse.Namespace, wm: WmClient) -> int:
    revision = await wm.define_relation(
        args.name, domain=args.domain, range=args.range, parent=args.parent,
        label=args.label, comment=args.comment,
    )  # fmt: skip
    print(f"relation {args.name} taught at revision {revision}")
    return 0


async def _define_property(args: argparse.Namespace, wm: WmClient) -> int:
    revision = await wm.define_property(
        args.name, kind=args.kind, domain=args.domain, minimum=args.min, maximum=args.max,
        label=args.label, comment=args.comment,
    )  # fmt: skip
    print(f"data property {args.name} ({args.kind}) taught at revision {revision}")
    return 0
