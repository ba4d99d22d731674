"""``skimesh sim --scenario S``: a scenario's MuJoCo world, its devices served on the mesh.

Opens a Zenoh session (client of a router by default), builds the world, steps it in real
time (or ``--fast``), serves every device on ``devices/<owner>/<device>/{cmd,state}`` and the
world's ground truth on ``sim/truth`` (:mod:`device_drivers.truth`: where the objects really
are, appliance states, the simulated time; what the task agent checks goals against), records
the run with rerun (``--rerun FILE``, default ``sim.rrd``; ``--no-rerun``; ``--rerun-connect
URL`` streams to a viewer; ``--images`` adds the cameras' images; the default layout of
:mod:`skimesh.recording` frames the robots and the work and labels them), and stops cleanly
on SIGINT/SIGTERM, on ``--duration`` simulated seconds, or when the simulation diverges (exit
code 1).
"""

from __future__ import annotations

import argparse
import logging
import os
from functools import partial
from pathlib import Path

import anyio

from meshlink import add_mesh_arguments

from ..paths import config_path
from ..runtime import run_service, settle_heap
from ._connect import service_mesh

__all__ = ["add_parser", "scenario_file"]

_log = logging.getLogger("skimesh.sim")


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "sim",
        help="simulate a scenario's world and serve its devices on the mesh",
        description="Build the MuJoCo world of a scenario, step it and serve every robot's "
        "devices on devices/<robot>/<device>/{cmd,state} and its ground truth on sim/truth.",
    )
    add_mesh_arguments(p)
    p.add_argument(
        "--scenario",
        default="kitting",
        help="scenario name (configs/scenarios/NAME/scenario.toml) or a scenario file "
        "(default: %(default)s)",
    )
    p.add_argument("--fast", action="store_true", help="as fast as possible, not real time")
    p.add_argument("--rerun", metavar="FILE", default="sim.rrd", help="record to this .rrd file")
    p.add_argument("--no-rerun", action="store_true", help="record no .rrd file")
    p.add_argument("--rerun-connect", metavar="URL", help="also stream to a rerun viewer")
    p.add_argument("--images", action="store_true", help="record camera images (needs EGL)")
    p.add_argument("--grasp", choices=("weld", "physics"), default="weld", help="grasp mode")
    p.add_argument("--state-rate", type=float, default=25.0, help="state publications, Hz")
    p.add_argument("--seed", type=int, default=0, help="seed of the sensor noise")
    p.add_argument("--duration", type=float, help="stop after this many simulated seconds")
    p.set_defaults(func=_run)


def scenario_file(name_or_path: str) -> Path:
    """A scenario file: an existing path, else ``configs/scenarios/<name>/scenario.toml``."""
    path = Path(name_or_path)
    if path.is_file():
        return path
    return config_path("scenarios", name_or_path, "scenario.toml")


def _run(args: argparse.Namespace) -> int:
    if args.images:  # before mujoco is imported: headless OpenGL through EGL
        os.environ.setdefault("MUJOCO_GL", "egl")
        os.environ.setdefault("EGL_PLATFORM", "surfaceless")
    from device_drivers.remote import serve_devices
    from device_drivers.truth import serve_truth
    from mujoco_sim import SimTruth, SimWorld, WorldOptions, sim_devices
    from mujoco_sim.recording import Recorder
    from scenario import load_scenario

    scenario = load_scenario(scenario_file(args.scenario))
    options = WorldOptions(fast=args.fast, grasp=args.grasp, seed=args.seed)
    path = None if args.no_rerun else args.rerun
    recorder = None
    if path or args.rerun_connect:
        recorder = Recorder(path=path, connect=args.rerun_connect, images=args.images)

    async def main() -> int:
        failure: BaseException | None = None
        world: SimWorld | None = None
        try:
            async with service_mesh(args, "sim") as mesh:
                world = await SimWorld.create(scenario, options, recorder)
                if recorder is not None:  # the layout framed on this world, and its labels
                    from ..recording import record_scene

                    await record_scene(recorder.rec, world, mission=False, images=args.images)
                devices = sim_devices(world)
                settle_heap()  # no full collections of the start-up heap (docs/benchmarks.md)
                async with anyio.create_task_group() as tg:
                    await tg.start(world.run)
                    serve = partial(serve_devices, state_rate=args.state_rate)
                    await tg.start(serve, mesh, devices)
                    await tg.start(serve_truth, mesh, SimTruth(world))
                    names = ", ".join(f"{o}/{d}" for o, d in devices)
                    _log.info(
                        "sim: scenario %s (%s), serving %s on mesh %s",
                        scenario.name,
                        "fast" if args.fast else "real time",
                        names,
                        mesh.config.mesh,
                    )
                    print(f"[sim] ready: {len(devices)} devices", flush=True)
                    if args.duration is None:
                        failure = await world.wait_stopped()
                    else:
                        await world.wait_time(args.duration)
                        failure = world.failure
                    tg.cancel_scope.cancel()
        finally:  # also on Ctrl-C / SIGTERM: say where the simulation stopped
            if world is not None:
                stats = world.statistics()
                print(
                    f"[sim] stopped at t={stats.sim_time:.2f} s, real-time factor "
                    f"{stats.real_time_factor:.2f}, {stats.slips} slip(s)",
                    flush=True,
                )
            if recorder is not None:
                await anyio.to_thread.run_sync(recorder.close)
        if failure is not None:
            _log.error("simulation failed: %s", failure)
            return 1
        return 0

    return run_service(main)
