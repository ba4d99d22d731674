"""A world-model writer process for the integration tests (run as a script, not collected).

Modes:
  cas    ``--count`` compare-and-set increments of the ``capacity`` of the element labelled
         ``counter``; retries on conflict; prints ``{"conflicts": n, "digest": ...}`` at the end.
  burst  adds elements labelled ``<name>-<i>`` with txn ids, printing ``{"ack": label}`` after each
         acknowledged transaction; stops quietly when the store goes away.
  follow writes nothing: only keeps its replica.
Then each line read on stdin is a revision: the worker waits until its replica reaches it and
prints ``{"digest": sha256 of its replica, "revision": r, "classes": {class: [superclasses]},
"templates": {template: class}}`` (classes and templates taught at run time, as its replica's
ontology knows them); it exits at end of input.
Every line on stdout is one JSON object; logs go to stderr.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys

import anyio
import msgspec

from meshlink import MeshConfig, open_mesh
from wm_store import ConflictError, TransportError, WmClient, ZenohTransport
from wm_store.protocol import AddElement


def emit(obj: object) -> None:
    sys.stdout.write(json.dumps(obj) + "\n")
    sys.stdout.flush()


def digest(wm: WmClient) -> str:
    snap = wm.replica.state.to_snapshot()
    snap.elements.sort(key=lambda e: e.id)
    snap.relations.sort(key=lambda r: (r.subject, r.predicate, r.object))
    return hashlib.sha256(msgspec.msgpack.encode(snap)).hexdigest()


async def cas(wm: WmClient, count: int) -> None:
    counter = wm.resolve_element(label="counter")[0].id
    conflicts = 0
    done = 0
    while done < count:
        element = wm.get_element(counter)
        value = element.properties.get("capacity", 0)
        assert isinstance(value, int)
        try:
            await wm.update_element(counter, {"capacity": value + 1}, expect_rev=element.rev)
            done += 1
        except ConflictError:
            conflicts += 1
            await wm.replica.sync()
    emit({"conflicts": conflicts})


async def burst(wm: WmClient, name: str, count: int) -> None:
    for i in range(count):
        label = f"{name}-{i}"
        try:
            await wm.transact([AddElement(type="Gear", label=label)], txn_id=label)
        except (TransportError, TimeoutError):
            emit({"stopped": label})
            return
        emit({"ack": label})


async def main(args: argparse.Namespace) -> None:
    config = MeshConfig(connect=(args.connect,), mesh=args.mesh)
    async with (
        open_mesh(config) as mesh,
        WmClient.connect(ZenohTransport(mesh), author=args.name, timeout=2.0) as wm,
    ):
        emit({"ready": wm.revision})
        if args.mode == "cas":
            await cas(wm, args.count)
        elif args.mode == "burst":
            await burst(wm, args.name, args.count)
        # Then answer digest requests: each stdin line is a revision to reach first.
        while line := await anyio.to_thread.run_sync(sys.stdin.readline):
            await wm.wait_for_revision(int(line))
            onto = wm.ontology
            classes = {c.name: list(onto.superclasses(c.name)) for c in onto.extended_classes}
            templates = {t.name: t.type for t in onto.extended_templates}
            emit(
                {
                    "digest": digest(wm),
                    "revision": wm.revision,
                    "classes": classes,
                    "templates": templates,
                }
            )


if __name__ == "__main__":
    parser = argparse.ArgumentParser()
    parser.add_argument("mode", choices=("cas", "burst", "follow"))
    parser.add_argument("--connect", required=True)
    parser.add_argument("--mesh", required=True)
    parser.add_argument("--name", default="w")
    parser.add_argument("--count", type=int, default=50)
    anyio.run(main, parser.parse_args())
