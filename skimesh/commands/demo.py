"""``skimesh demo``: the whole system on loopback, in one process.

Today (world-model milestone): start a Zenoh router and the world-model store (durable, in a
temporary or given data directory), connect a client over Zenoh as any agent would, load the
scenario's scene, print it as a tree, and stop cleanly. Later milestones add the simulator,
the skill agents and the task agent to the same command.
"""

from __future__ import annotations

import argparse
import logging
import tempfile
import time
from pathlib import Path

import anyio

from meshlink import MeshConfig, open_mesh, run_router
from wm_store import (
    Ontology,
    StoreConfig,
    WmClient,
    WmStore,
    ZenohTransport,
    import_turtle,
    serve_store,
)

from ..paths import config_path
from ..render import render_tree
from ..runtime import run_service

__all__ = ["add_parser"]

_log = logging.getLogger("skimesh.demo")


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "demo",
        help="run everything on loopback in one process",
        description="Start a router and the world model on loopback, load the scenario's "
        "scene through a Zenoh client and print it as a tree.",
    )
    p.add_argument("--scenario", default="kitting", help="scenario name (default: kitting)")
    p.add_argument("--data", metavar="DIR", help="world-model data directory (default: a temp dir)")
    p.add_argument(
        "--port", type=int, default=0, help="router port on 127.0.0.1 (default: free port)"
    )
    p.set_defaults(func=_run)


def _free_port() -> int:
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _run(args: argparse.Namespace) -> int:
    scene = config_path("scenes", "sample.ttl")
    scene_text = scene.read_text()
    port = args.port or _free_port()
    endpoint = f"tcp/127.0.0.1:{port}"

    async def main() -> int:
        with tempfile.TemporaryDirectory(prefix="skimesh-wm-") as tmp:
            data_dir = Path(args.data or tmp)
            started = time.monotonic()
            ontology = Ontology.default()
            store = await WmStore.open(ontology, StoreConfig(data_dir=str(data_dir)))
            async with anyio.create_task_group() as tg:
                await tg.start(run_router, [endpoint])
                print(f"[demo] router listening on {endpoint}")
                server_cfg = MeshConfig(connect=(endpoint,))
                async with open_mesh(server_cfg) as server_mesh:
                    await tg.start(serve_store, server_mesh, store)
                    print(f"[demo] world model serving (data in {data_dir})")
                    async with (
                        open_mesh(MeshConfig(connect=(endpoint,))) as mesh,
                        WmClient.connect(ZenohTransport(mesh), author="demo") as wm,
                    ):
                        ops = import_turtle(scene_text, wm.ontology, state=wm.replica.state)
                        reply = await wm.transact(ops)
                        print(
                            f"[demo] loaded scene {scene.name}: {len(wm.replica.state.elements)} "
                            f"elements, revision {reply.revision}"
                        )
                        print(render_tree(wm.replica.state))
                    tg.cancel_scope.cancel()
            print(f"[demo] stopped cleanly after {time.monotonic() - started:.1f} s")
        return 0

    return run_service(main)
