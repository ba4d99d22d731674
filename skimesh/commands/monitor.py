"""``skimesh monitor --scenario S``: follow a running site into rerun, from any host of the mesh.

Joins the mesh (a client of its router), builds the scenario's model locally (the same
scenario file the site runs) and records, in the demo's layout: the 3-D world posed from the
devices' states and the objects' poses (the simulator's ground truth on ``sim/truth`` when
one answers, else the world model's beliefs), every task's events (a task running at the
start from its kept history), the plan and its graph, each robot's step and progress, the
world-model changes in words, the beliefs' ghosts and the agents' event logs
(:mod:`skimesh.monitor`).

Where it goes: ``--rrd FILE`` (default ``monitor.rrd`` when nothing else is asked),
``--connect-viewer [URL]`` (a running viewer, ``rerun`` started on this or another host),
``--serve-web`` (rerun's web viewer served on ``--bind``, its data on ``--grpc-port``);
any of them together. Stops cleanly on SIGINT / SIGTERM or after ``--duration`` wall seconds
(the ``.rrd`` is finished): exit code 0.
"""

from __future__ import annotations

import argparse
import logging
import os
import socket
import sys
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING, Any

import anyio

from meshlink import add_mesh_arguments

from ..runtime import run_service
from ._connect import service_mesh, store_answers

if TYPE_CHECKING:
    from mujoco_sim.recording import Recorder

    from ..monitor import Monitor


__all__ = ["DEFAULT_VIEWER", "add_parser"]

_log = logging.getLogger("skimesh.monitor")

DEFAULT_VIEWER = "rerun+http://127.0.0.1:9876/proxy"
"""Where ``--connect-viewer`` streams without a URL: a viewer started by ``rerun`` here."""


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "monitor",
        help="follow a running site into rerun: world, tasks, plan, changes, agents' logs",
        description="Follow the mesh into rerun with the demo's layout: the scenario's world "
        "posed from the devices' states and the objects' poses, every task (a running one "
        "from its history), the plan, each robot's step, world-model changes and beliefs, "
        "the agents' event logs. Runs on any host of the mesh.",
    )
    add_mesh_arguments(p)
    p.add_argument(
        "--scenario",
        default="kitting",
        help="the scenario the site runs: a shipped name or a scenario file (default: %(default)s)",
    )
    p.add_argument("--rrd", metavar="FILE", help="record to this .rrd file (default: "
                   "monitor.rrd unless --connect-viewer or --serve-web)")  # fmt: skip
    p.add_argument("--connect-viewer", metavar="URL", nargs="?", const=DEFAULT_VIEWER,
                   help=f"stream to a running viewer (default URL: {DEFAULT_VIEWER})")  # fmt: skip
    p.add_argument("--serve-web", action="store_true",
                   help="serve rerun's web viewer (http://BIND:WEB_PORT)")  # fmt: skip
    p.add_argument("--bind", default="127.0.0.1", help="address the recording's data is served "
                   "on with --serve-web (default: %(default)s; rerun serves the viewer's page, "
                   "static files, on every interface)")  # fmt: skip
    p.add_argument("--web-port", type=int, default=9090, help="web viewer port (default: 9090)")
    p.add_argument("--grpc-port", type=int, default=9876,
                   help="port of the data the web viewer reads (default: 9876)")  # fmt: skip
    p.add_argument("--images", action="store_true", help="render the scenario's cameras from "
                   "the mirrored world (needs EGL)")  # fmt: skip
    p.add_argument("--rate", type=float, default=25.0, help="world samples per second")
    p.add_argument("--truth-period", type=float, default=0.2, metavar="S",
                   help="seconds between two requests of the objects' poses")  # fmt: skip
    p.add_argument("--recent", type=float, default=0.0, metavar="S", help="also record the "
                   "tasks that ended in the last S seconds, from their history")  # fmt: skip
    p.add_argument("--timeout", type=float, default=5.0, help="seconds to wait for a service")
    p.add_argument("--duration", type=float, metavar="S", help="stop after S wall seconds")
    p.set_defaults(func=_run)


def _recorder(args: argparse.Namespace) -> tuple[Recorder, list[str]]:
    """The recorder with the sinks asked for, and a line per sink."""
    import rerun as rr

    from mujoco_sim.recording import Recorder

    recorder = Recorder(application="skimesh-monitor", images=args.images)
    sinks: list[Any] = []
    lines: list[str] = []
    rrd = args.rrd or (None if args.connect_viewer or args.serve_web else "monitor.rrd")
    if rrd:
        Path(rrd).resolve().parent.mkdir(parents=True, exist_ok=True)
        sinks.append(rr.FileSink(str(rrd)))
        lines.append(f"recording to {rrd}")
    if args.connect_viewer:
        sinks.append(rr.GrpcSink(args.connect_viewer))
        lines.append(f"streaming to the viewer at {args.connect_viewer}")
    if args.serve_web:
        sinks.append(rr.GrpcServerSink(bind_ip=args.bind, port=args.grpc_port))
        host = socket.gethostname() if args.bind in ("0.0.0.0", "::") else args.bind
        data = f"rerun+http://{host}:{args.grpc_port}/proxy"
        rr.serve_web_viewer(web_port=args.web_port, open_browser=False, connect_to=data)
        lines.append(f"web viewer: http://{host}:{args.web_port}/?url={data}")
    recorder.rec.set_sinks(*sinks)
    return recorder, lines


def _run(args: argparse.Namespace) -> int:
    if args.images:  # before mujoco is imported: headless OpenGL through EGL
        os.environ.setdefault("MUJOCO_GL", "egl")
        os.environ.setdefault("EGL_PLATFORM", "surfaceless")
    from scenario import load_scenario

    from ..monitor import MonitorOptions, run_monitor
    from .sim import scenario_file

    scenario = load_scenario(scenario_file(args.scenario))
    options = MonitorOptions(
        scenario=scenario,
        images=args.images,
        rate=args.rate,
        truth_period=args.truth_period,
        timeout=args.timeout,
        recent=args.recent,
    )
    recorder, lines = _recorder(args)

    def say(text: str) -> None:
        print(f"[monitor] {text}", flush=True)

    async def main() -> int:
        try:
            async with service_mesh(args, "monitor") as mesh:
                await store_answers(mesh, "monitor", timeout=args.timeout)
                async with anyio.create_task_group() as tg:
                    started = partial(run_monitor, mesh, options, recorder, say=say)
                    monitor: Monitor = await tg.start(started)
                    for line in lines:
                        say(line)
                    _log.info(  # a service says it is up (as the others do)
                        "monitor ready: scenario %s, mesh %s", scenario.name, mesh.config.mesh
                    )
                    if args.duration is not None:
                        await anyio.sleep(args.duration)
                        tg.cancel_scope.cancel()
                    else:
                        await anyio.sleep_forever()
                say(
                    f"stopped: {monitor.mission.events} task events of "
                    f"{len(monitor.mission.followed)} task(s), {monitor.world.states} device "
                    f"states, objects from {monitor.world.source}"
                )
        finally:
            with anyio.CancelScope(shield=True):
                await anyio.to_thread.run_sync(recorder.close)  # finishes the .rrd
        return 0

    try:
        return run_service(main)
    except KeyboardInterrupt:  # pragma: no cover - a second Ctrl-C during the close
        print("skimesh monitor: interrupted", file=sys.stderr)
        return 130
