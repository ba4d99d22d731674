"""``skimesh demo [--scenario kitting|meal]``: the whole mission in one command.

In one process, on loopback only: a Zenoh router, the durable world model (a temporary data
directory, or ``--data DIR``) loaded with the scenario's scene, the MuJoCo world, one skill
agent per robot (and the microwave's own agent for ``meal``) driving the world's devices
in-process, and the task agent (:mod:`skimesh.demo`). Then the scenario's goal (or
``--goal``) goes to the task agent; the terminal shows the plan and every step of every robot
(:mod:`skimesh.demo`); at the end each goal fact is checked in the world model *and* in
the physics, and a summary says what happened and where the recording is.

Exit codes: 0 the task succeeded and the goal holds in the world model and in the physics;
1 it did not; 2 the demo could not start (bad scenario, goal, data directory); 130 stopped
by Ctrl-C / SIGTERM (the task is aborted: every run stops and its robot goes to a safe state;
sessions close and the recording is flushed; a second Ctrl-C stops at once).

Recording (rerun): ``run.rrd`` in the current directory by default (``--rrd``): the 3-D scene
over time, each robot's active skill and progress, task events, replans, the plan, every
world-model change, labels on robots and objects, where the world model believes each object
is (ghosts), and the scenario's cameras (rendered headless through EGL; without EGL the run
goes on without images; ``--no-images`` leaves them out); the default layout frames the robots
and the work (:mod:`skimesh.recording`). ``--rerun-connect URL`` also streams to a running viewer;
``--rerun-serve`` serves the recording on 127.0.0.1 for a viewer to connect to later (the
command then waits for Ctrl-C after the summary).
"""

from __future__ import annotations

import argparse
import logging
import os
import signal
import sys
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING, Any

import anyio
import msgspec

from ..errors import Exit

if TYPE_CHECKING:
    from mujoco_sim.recording import Recorder
    from scenario import Scenario

    from ..demo import DemoSetup

__all__ = ["add_parser", "mission_goal"]

EXIT_SETUP, EXIT_INTERRUPTED = Exit.REFUSED, Exit.INTERRUPTED


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "demo",
        help="the whole mission in one process, on loopback",
        description="Router, world model, MuJoCo world, skill agents and task agent in one "
        "process on loopback; submit the scenario's goal, show every step, verify the goal "
        "in the world model and in the physics, record everything to an .rrd file. Exit code "
        "0 only if the goal holds in both.",
    )
    p.add_argument(
        "--scenario",
        default="kitting",
        help="a shipped scenario (kitting, meal, workshop, kitting-panda) or a scenario file "
        "(default: %(default)s)",
    )
    p.add_argument(
        "--ontology",
        action="append",
        default=[],
        metavar="TTL",
        help="teach the world model the terms of this Turtle file too (repeatable; "
        "a scenario file can list its own under `ontology`)",
    )
    p.add_argument("--goal", help="goal facts instead of the scenario's, e.g. "
                   '"contain(KitBox-1, Gear-1) and contain(KitBox-2, Bolt-2)"')  # fmt: skip
    p.add_argument("--data", metavar="DIR", help="world-model data directory (empty or new; "
                   "default: a temporary one, removed at the end)")  # fmt: skip
    pace = p.add_mutually_exclusive_group()
    pace.add_argument("--fast", dest="fast", action="store_true", default=True,
                      help="simulate as fast as possible (default)")  # fmt: skip
    pace.add_argument("--realtime", dest="fast", action="store_false",
                      help="simulate in real time")  # fmt: skip
    p.add_argument("--rrd", default="run.rrd", metavar="FILE",
                   help="write the recording here (default: %(default)s)")  # fmt: skip
    p.add_argument("--rerun-connect", metavar="URL", help="also stream to a rerun viewer, "
                   "e.g. rerun+http://127.0.0.1:9876/proxy")  # fmt: skip
    p.add_argument("--rerun-serve", action="store_true", help="serve the recording on "
                   "127.0.0.1 for a viewer to connect later")  # fmt: skip
    p.add_argument("--rerun-port", type=int, default=9876, help="port of --rerun-serve")
    p.add_argument("--images", action=argparse.BooleanOptionalAction, default=True,
                   help="record the scenario's camera images (rendered headless through EGL; "
                   "none without EGL; default: on, --no-images leaves them out)")  # fmt: skip
    p.add_argument("--port", type=int, default=0, help="router port on 127.0.0.1 (default: free)")
    p.add_argument("--seed", type=int, default=0, help="seed of the simulated sensor noise")
    p.add_argument("--max-replans", type=int, default=5, metavar="N",
                   help="replans allowed after failed steps (default: %(default)s)")  # fmt: skip
    p.add_argument("--planner-timeout", type=float, default=60.0, metavar="S",
                   help="give up planning (each plan, each replan) after S seconds")  # fmt: skip
    p.add_argument("--deadline", type=float, default=1800.0, metavar="S",
                   help="give up on the task after this many wall seconds")  # fmt: skip
    p.set_defaults(func=_run)


def mission_goal(scenario: Scenario) -> str:
    """The scenario's goals, and every appliance left with its door closed (a robot must not
    leave a microwave open; the scenario file's goal syntax cannot say "not")."""
    tidy = [f"doorOpen({a.label}) = false" for a in scenario.appliances]
    return " and ".join([*scenario.goals, *tidy])


def _recorder(args: argparse.Namespace, rrd: Path) -> Recorder:
    """The world's recorder, writing ``rrd`` (and streaming / serving when asked); the demo
    sends the viewer layout once the world is built (:func:`skimesh.recording.record_scene`)."""
    import rerun as rr

    from mujoco_sim.recording import Recorder

    recorder = Recorder(application="skimesh-demo", images=args.images)
    sinks: list[Any] = [rr.FileSink(str(rrd))]
    if args.rerun_connect:
        sinks.append(rr.GrpcSink(args.rerun_connect))
    if args.rerun_serve:
        sinks.append(rr.GrpcServerSink(bind_ip="127.0.0.1", port=args.rerun_port))
    recorder.rec.set_sinks(*sinks)
    return recorder


def _quiet_services(verbosity: int) -> None:
    """The services' "ready" lines are warnings (so a lone service says it is up); the demo
    prints its own start-up lines instead."""
    if verbosity == 0:
        for name in ("skill_agent.server", "task_agent.service"):
            logging.getLogger(name).setLevel(logging.ERROR)


def _setup(args: argparse.Namespace, data: Path) -> DemoSetup:
    """Read the scenario and the agents' configurations (files: before the loop runs)."""
    from scenario import load_scenario

    from ..demo import DemoSetup, agent_configs
    from .sim import scenario_file

    scenario = load_scenario(scenario_file(args.scenario))
    if args.ontology:  # the scenario's own terms, then these: all taught to the world model
        for name in args.ontology:
            if not Path(name).is_file():
                raise ValueError(f"--ontology: no file {name}")
        extra = [str(Path(n).resolve()) for n in args.ontology]
        scenario = msgspec.structs.replace(scenario, ontology=[*scenario.ontology, *extra])
    goal = args.goal or mission_goal(scenario)
    if not goal:
        raise ValueError(f"scenario {scenario.name!r} has no goals; give --goal")
    return DemoSetup(
        scenario=scenario,
        agents=agent_configs(scenario),
        goal=goal,
        rrd=Path(args.rrd).resolve(),
        data=data,
        fast=args.fast,
        seed=args.seed,
        port=args.port,
        max_replans=args.max_replans,
        planner_timeout=args.planner_timeout,
        deadline=args.deadline,
        images=args.images,
    )


def _run(args: argparse.Namespace) -> int:
    from scenario import ScenarioError
    from skill_agent import SkillError

    from ..errors import DemoError

    _quiet_services(args.verbose)
    if args.images:  # before mujoco is imported: headless OpenGL through EGL
        os.environ.setdefault("MUJOCO_GL", "egl")
        os.environ.setdefault("EGL_PLATFORM", "surfaceless")
    with tempfile.TemporaryDirectory(prefix="skimesh-demo-") as tmp:
        try:
            setup = _setup(args, Path(args.data).resolve() if args.data else Path(tmp))
        except (ScenarioError, SkillError, DemoError, FileNotFoundError, ValueError) as e:
            print(f"skimesh demo: {e}", file=sys.stderr)
            return EXIT_SETUP
        setup.rrd.parent.mkdir(parents=True, exist_ok=True)
        recorder = _recorder(args, setup.rrd)
        return anyio.run(_main, args, setup, recorder)


async def _main(args: argparse.Namespace, setup: DemoSetup, recorder: Recorder) -> int:
    from ..demo import run_demo

    stop = anyio.Event()
    code: int = EXIT_SETUP
    async with anyio.create_task_group() as tg:
        tg.start_soon(_signals, stop, tg.cancel_scope)
        try:
            code = await run_demo(setup, recorder, stop)
            if args.rerun_serve and not stop.is_set():
                url = f"rerun+http://127.0.0.1:{args.rerun_port}/proxy"
                print(f"[demo] serving the recording: `rerun {url}` (Ctrl-C to stop)", flush=True)
                await stop.wait()
        finally:
            with anyio.CancelScope(shield=True):
                await anyio.to_thread.run_sync(recorder.close)  # finishes the .rrd
        tg.cancel_scope.cancel()
    return EXIT_INTERRUPTED if stop.is_set() and code != 0 else code


async def _signals(stop: anyio.Event, everything: anyio.CancelScope) -> None:
    """First SIGINT / SIGTERM: stop gracefully (``stop``); the second: cancel everything."""
    with anyio.open_signal_receiver(signal.SIGINT, signal.SIGTERM) as signals:
        async for signum in signals:
            if stop.is_set():
                print("[demo] second signal: stopping at once", file=sys.stderr, flush=True)
                everything.cancel()
                return
            name = signal.Signals(signum).name
            print(f"\n[demo] {name}: stopping (again to force)", file=sys.stderr, flush=True)
            stop.set()
