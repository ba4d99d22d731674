"""The editing and following sub-commands of ``skimesh wm``: ``add``, ``update``,
``remove``, ``relate``, ``unrelate`` write the world model (one transaction each, checked by
the store as any write: the ontology's classes, properties, domains, cardinalities, the scene
tree, unique names); ``watch`` prints every change as it is committed, in words (what each
update changed, against the state before it: :class:`~wm_store.ChangeWords`); ``history``
prints the changes since a revision (those the store still keeps), learning the elements as
it goes.

Values given as ``PROP=VALUE`` are JSON (typed values such as poses, lists) or a number,
``true``/``false`` or text.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Awaitable, Callable

import msgspec

from wm_store import ChangeWords, WmClient, display_name
from wm_store.protocol import (
    AddElement,
    Change,
    ChangesReply,
    ChangesSince,
    Relation,
    Value,
)

from ..runtime import run_service
from ._connect import wm_session
from ._store_reads import element_ids

__all__ = ["Body", "add_edit_commands", "client", "parse_assignments"]

Body = Callable[[argparse.Namespace, WmClient], Awaitable[int]]
_VALUES = "PROP=VALUE: JSON (a pose, a list), a number, true/false or text"


def add_edit_commands(cmds: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add ``add``, ``update``, ``remove``, ``relate``, ``unrelate``, ``watch``, ``history``."""
    add = cmds.add_parser(
        "add",
        help="add an element",
        description="Add an element of class TYPE, e.g. `skimesh wm add Gear --label gear-7 "
        "--set mass=0.1 --in PartBox-1`. Prints its id.",
    )
    add.add_argument("type", help="its class, e.g. Gear")
    add.add_argument("--label", default="", help="its label (unique in the scene)")
    add.add_argument("--set", action="append", default=[], metavar="PROP=VALUE", help=_VALUES)
    add.add_argument(
        "--in",
        dest="parent",
        metavar="ID",
        help="its spatial parent (an id, or a label only it has)",
    )
    add.add_argument(
        "--relation", default="contain", help="how the parent holds it (default: contain)"
    )
    add.set_defaults(func=lambda a: client(a, _add))

    upd = cmds.add_parser(
        "update",
        help="change an element's properties or label",
        description="Merge properties into an element (`--set`), remove some (`--unset`), "
        "relabel it (`--label`), e.g. `skimesh wm update Gear-1 --set mass=0.2`.",
    )
    upd.add_argument("id", help="the element: its id (Gear-1) or a label only it has")
    upd.add_argument("--set", action="append", default=[], metavar="PROP=VALUE", help=_VALUES)
    upd.add_argument("--unset", action="append", default=[], metavar="PROP", help="remove it")
    upd.add_argument("--label", default=None, help="a new label")
    upd.set_defaults(func=lambda a: client(a, _update))

    rm = cmds.add_parser(
        "remove",
        help="remove an element",
        description="Remove an element (`--branch`: with everything it spatially holds).",
    )
    rm.add_argument("id", help="the element: its id (Gear-1) or a label only it has")
    rm.add_argument("--branch", action="store_true", help="with everything it holds")
    rm.set_defaults(func=lambda a: client(a, _remove))

    for name, verb in (("relate", "set"), ("unrelate", "unset")):
        rel = cmds.add_parser(
            name,
            help=f"{verb} a relation SUBJECT PREDICATE OBJECT",
            description=f"{verb.capitalize()} a relation, e.g. `skimesh wm {name} KitBox-1 "
            "contain Gear-1` (a spatial relation moves the object in the scene tree).",
        )
        rel.add_argument("subject", help="an element: its id or a label only it has")
        rel.add_argument("predicate", help="a relation of the ontology, e.g. contain")
        rel.add_argument("object", help="an element: its id or a label only it has")
        rel.set_defaults(func=lambda a, n=name: client(a, _relate if n == "relate" else _unrelate))

    watch = cmds.add_parser(
        "watch",
        help="print every change of the world model as it is committed",
        description="Follow the world model: one line per committed transaction (revision, "
        "author, what it did), until Ctrl-C. --json: each change as JSON.",
    )
    watch.add_argument("--json", action="store_true", help="one JSON change per line")
    watch.set_defaults(func=lambda a: client(a, _watch))

    hist = cmds.add_parser(
        "history",
        help="print the changes since a revision",
        description="The changes the store still keeps after revision --since (default: "
        "all it keeps), one line each. --json: as JSON.",
    )
    hist.add_argument("--since", type=int, default=0, metavar="REV", help="after this revision")
    hist.add_argument("--json", action="store_true", help="one JSON change per line")
    hist.set_defaults(func=lambda a: client(a, _history))


def parse_assignments(items: list[str]) -> dict[str, Value]:
    """``PROP=VALUE`` items as properties; SystemExit naming a malformed one."""
    out: dict[str, Value] = {}
    for item in items:
        name, sep, raw = item.partition("=")
        if not sep or not name:
            raise SystemExit(f"--set takes PROP=VALUE, not {item!r}")
        try:
            out[name] = msgspec.json.decode(raw.encode(), type=Value)
        except msgspec.DecodeError:
            out[name] = raw  # plain text
    return out


def client(args: argparse.Namespace, body: Body) -> int:
    """Run ``body`` with a world-model client for one command; its exit code."""

    async def main() -> int:
        async with wm_session(args) as wm:
            return await body(args, wm)

    return run_service(main)


def _id(wm: WmClient, name: str) -> str:
    """The element ``name`` gives: an id, or a label only one element has."""
    return element_ids([name], wm.replica.state.elements.values())[0]


async def _add(args: argparse.Namespace, wm: WmClient) -> int:
    parent = _id(wm, args.parent) if args.parent else ""
    relations = [Relation(parent, args.relation, "$")] if parent else []
    op = AddElement(
        type=args.type,
        label=args.label,
        properties=parse_assignments(args.set),
        relations=relations,
        ref="$new",
    )
    reply = await wm.transact([op])
    print(reply.ids["$new"])
    return 0


async def _update(args: argparse.Namespace, wm: WmClient) -> int:
    properties = parse_assignments(args.set)
    if not (properties or args.unset or args.label is not None):
        raise SystemExit("nothing to change: give --set, --unset or --label")
    eid = _id(wm, args.id)
    revision = await wm.update_element(eid, properties, remove=args.unset, label=args.label)
    print(f"{display_name(wm.find_element(eid), eid)} updated at revision {revision}")
    return 0


async def _remove(args: argparse.Namespace, wm: WmClient) -> int:
    eid = _id(wm, args.id)
    name = display_name(wm.find_element(eid), eid)
    if args.branch:
        revision = await wm.remove_branch(eid)
    else:
        revision = await wm.remove_element(eid)
    print(f"{name} removed at revision {revision}")
    return 0


async def _relate(args: argparse.Namespace, wm: WmClient) -> int:
    revision = await wm.set_relation(_id(wm, args.subject), args.predicate, _id(wm, args.object))
    print(f"{args.predicate}({args.subject}, {args.object}) set at revision {revision}")
    return 0


async def _unrelate(args: argparse.Namespace, wm: WmClient) -> int:
    subject, obj = _id(wm, args.subject), _id(wm, args.object)
    revision = await wm.unset_relation(subject, args.predicate, obj)
    print(f"{args.predicate}({args.subject}, {args.object}) unset at revision {revision}")
    return 0


def _line(change: Change, wm: WmClient, words: ChangeWords, as_json: bool) -> str:
    """The change as JSON, or in words against what ``words`` knew before it (elements it
    never saw named as the replica names them)."""
    if as_json:
        return msgspec.json.encode(change).decode()
    return words(change, lambda i: display_name(wm.find_element(i), i))


async def _watch(args: argparse.Namespace, wm: WmClient) -> int:
    print(f"# world model at revision {wm.revision}; following (Ctrl-C stops)", file=sys.stderr)
    async with wm.watch() as changes:
        # the stream holds the changes after this point; the replica runs ahead of them
        words = ChangeWords(wm.replica.state.elements.values(), revision=wm.revision)
        async for change in changes:
            print(_line(change, wm, words, args.json), flush=True)
    return 0


async def _history(args: argparse.Namespace, wm: WmClient) -> int:
    reply = await wm.request(ChangesSince(revision=max(0, args.since)))
    assert isinstance(reply, ChangesReply)
    words = ChangeWords()  # the state before --since is not known: learnt change by change
    for change in reply.changes:
        print(_line(change, wm, words, args.json))
    return 0
