"""Simulation benchmark: each scenario with every robot and driver working, beside bare
``mj_step`` of the same model driven by the same set-points, in the same run.

    python -m benchmarks.sim                         # full run (~2.5 min on 2 cores)
    python -m benchmarks.sim --quick                 # smoke run
    python -m benchmarks.sim --in-process            # the single-process layout only
    python -m benchmarks.sim --layout router-apart   # any layouts, the first one headline
    python -m benchmarks.sim --json results.json

Per scenario (method and results: ``docs/benchmarks.md``, section "Simulation"):

1. **full system, fast mode**: ``SimWorld`` (controllers at 100 Hz, IK every tick of straight
   moves, grasp logic, sensors) with every device served over Zenoh (states published at
   25 Hz) and rerun logging to a file, driven by a workload written against the device
   Protocols (``benchmarks.sim_workload``: pick-and-place on every robot at once, sensors read
   every 0.5 s) through the remote proxies. Layouts (``benchmarks.sim_system``): *deployed*,
   the headline, with the router, the world and its device server in this process and the
   workload in a client process of its own (``benchmarks.sim_client``), as skill agents are;
   *in-process*, the client's session and workload in this process too (its loop, its GIL);
   *router-apart* (on request), as deployed with the router in a process of its own. Figure:
   wall time of this process per simulated second.
2. **baseline**: a fresh copy of the same model stepped with bare ``mj_step(m, d, nstep=5)``
   per control tick, replaying the exact set-points, weld switches, weld poses and gripper
   force limits the controllers produced in run 1 (recorded every tick), from its start (the
   ticks before the measured window untimed), right after it: the run's physics bit for bit
   (:func:`step_through`). Ratio = overhead;
   target < 2x. Runs 1 and 2 are repeated (``--repeat``, 9 by default; the layouts take turns
   going first): figures are medians, the ratio the median of the pairs' ratios.
3. bare stepping at rest (no motion); real time: the same system paced by the wall clock in
   the headline layout (target: real-time factor 1, no slips); the CPU an idle world costs in
   real time (beside bare stepping at rest); pick-and-place success; stop-to-halt time.

Child processes (client, router) are ``sys.executable`` children of this script (``--role``),
on 127.0.0.1 only (free port, multicast scouting off), always stopped by their PID.
"""

from __future__ import annotations

import argparse
import contextlib
import statistics
import sys
import tempfile
import time
from collections.abc import Sequence
from functools import partial
from pathlib import Path
from typing import Any

import anyio
import msgspec
import mujoco

from benchmarks.common import (
    ROOT,
    Row,
    calibrate,
    child_router,
    format_table,
    load_average,
    machine_info,
)
from benchmarks.sim_client import child_client
from benchmarks.sim_system import LAYOUTS, full_system
from benchmarks.sim_workload import WORKLOADS
from device_drivers.drivers import sim_devices
from device_drivers.errors import MotionStoppedError
from device_drivers.interfaces import Arm
from device_drivers.plant import Plant
from device_drivers.protocol import Stop
from device_drivers.scenario import Scenario
from device_drivers.scenario_load import load_scenario
from device_drivers.world import WorldOptions, running_world


def replay(scenario: Scenario, ticks: Sequence[Any], timed_from: int = 0) -> tuple[float, float]:
    """Wall and simulated seconds of stepping a fresh copy of the world through
    ``ticks[timed_from:]`` with bare mj_step (see :func:`step_through`)."""
    plant = Plant(scenario)
    wall = step_through(plant, ticks, timed_from)
    return wall, (len(ticks) - timed_from) * plant.tick_time


def step_through(plant: Plant, ticks: Sequence[Any], timed_from: int = 0) -> float:
    """Step ``plant`` through the recorded ``ticks`` (:meth:`~benchmarks.sim_system.Tap.ticks`)
    with bare ``mj_step``; return the wall seconds from tick ``timed_from`` on. From the same
    start this is the run's physics, bit for bit (``tests/unit/benchmarks``)."""
    m, d, n = plant.model, plant.data, plant.steps_per_tick
    start = time.perf_counter()
    for i, (ctrl, active, force, eq) in enumerate(ticks):
        if i == timed_from:
            start = time.perf_counter()
        d.ctrl[:] = ctrl
        d.eq_active[:] = active
        m.actuator_forcerange[:] = force
        m.eq_data[:] = eq
        mujoco.mj_step(m, d, nstep=n)
    return time.perf_counter() - start


def at_rest(scenario: Scenario, seconds: float) -> float:
    """Wall seconds per simulated second of bare stepping with nothing moving."""
    plant = Plant(scenario)
    steps = round(seconds / plant.model.opt.timestep)
    start = time.perf_counter()
    mujoco.mj_step(plant.model, plant.data, nstep=steps)
    return (time.perf_counter() - start) / seconds


async def idle_real_time(scenario: Scenario, seconds: float) -> float:
    """CPU seconds of this process per wall second while the world runs in real time with
    nothing commanded (no recorder, no Zenoh): what an idle simulator costs its host."""
    async with running_world(scenario, WorldOptions()) as world:
        await world.wait_time(world.snapshot.time + 0.3)  # started and settled
        cpu, wall = time.process_time(), time.perf_counter()
        await anyio.sleep(seconds)
        return (time.process_time() - cpu) / (time.perf_counter() - wall)


async def _move_until_stopped(arm: Arm, goal: dict[str, float]) -> None:
    with contextlib.suppress(MotionStoppedError):
        await arm.move_joints(goal, duration=2.0)


async def stop_to_halt(scenario: Scenario, repeats: int) -> list[float]:
    """Simulated seconds from ``stop()`` to the arm standing still (< 0.02 rad/s), stopped
    0.8 s into a 2 s move (near its top speed), to one control tick (10 ms)."""
    found: list[float] = []
    async with running_world(scenario, WorldOptions(fast=True)) as world:
        robot = scenario.robots[0].name
        arm = sim_devices(world, robot)[(robot, "arm")]
        assert isinstance(arm, Arm)
        for i in range(repeats):
            goal = {"shoulder_lift": 0.9, "elbow": 1.4} if i % 2 == 0 else {"shoulder_lift": 0.1}
            async with anyio.create_task_group() as tg:
                tg.start_soon(_move_until_stopped, arm, goal)
                await world.sleep(0.8)
                # the driver's stop() is this command; its result is the settling time
                found.append(await world.execute((robot, "arm"), Stop()))
    return found


async def measure(
    name: str,
    quick: bool,
    repeat: int,
    layouts: Sequence[str],
    workdir: Path,
    period: float = 0.5,
) -> dict[str, Any]:
    """Runs 1 and 2 ``repeat`` times per layout (each fast run right before the replay of its
    own ticks, so that both see about the same machine; the layouts take turns going first);
    per layout the figures are the medians, the overhead ratio the median of the pairs'.
    ``period``: the workload reads every sensor every ``period`` simulated s (0: never)."""
    scenario = load_scenario(ROOT / "configs" / "scenarios" / name / "scenario.toml")
    picks = 1 if quick else 2
    runs: dict[str, list[dict[str, Any]]] = {layout: [] for layout in layouts}
    for i in range(repeat):
        for layout in layouts if i % 2 == 0 else layouts[::-1]:
            rrd = workdir / f"{name}-{layout}-{i}.rrd"
            fast = await full_system(
                scenario, layout=layout, fast=True, picks=picks, rrd=rrd, sensor_period=period
            )
            bare, bare_sim = await anyio.to_thread.run_sync(
                replay, scenario, fast["ticks"], fast["first_tick"]
            )
            sim = fast["sim"]
            runs[layout].append(
                {
                    "sim_s": sim,
                    "full": fast["wall"] / sim,
                    "bare": bare / bare_sim,
                    "cpu": fast["cpu"] / sim,
                    "client_cpu": fast["client_cpu"] / sim,
                    "success": fast["success"],
                    "rrd_bytes": rrd.stat().st_size,
                }
            )
    rest = await anyio.to_thread.run_sync(at_rest, scenario, 5.0 if quick else 20.0)
    real = await full_system(
        scenario,
        layout=layouts[0],
        fast=False,
        picks=picks,
        rrd=workdir / f"{name}-rt.rrd",
        limit=4 if quick else 10,
        sensor_period=period,
    )
    halts = await stop_to_halt(scenario, 3 if quick else 10)
    idle = await idle_real_time(scenario, 2.0 if quick else 5.0)
    every = [r for layout in layouts for r in runs[layout]]
    success = {p: all(r["success"][p] for r in every) for p in every[0]["success"]}
    return {
        "layouts": {layout: _summary(found) for layout, found in runs.items()},
        "rest_wall_per_sim_s": rest,
        "idle_real_time_cpu": idle,
        "success": success,
        "real_time_layout": layouts[0],
        "real_time_factor": real["sim"] / real["wall"],
        "real_time_slips": real["slips"],
        "stop_to_halt_s": halts,
        "rrd_bytes": every[0]["rrd_bytes"],
    }


def _summary(runs: list[dict[str, Any]]) -> dict[str, Any]:
    def median(key: str) -> float:
        return float(statistics.median(r[key] for r in runs))

    return {
        "sim_s": median("sim_s"),
        "full_wall_per_sim_s": median("full"),
        "bare_wall_per_sim_s": median("bare"),
        "cpu_per_sim_s": median("cpu"),
        "client_cpu_per_sim_s": median("client_cpu"),
        "overhead": statistics.median(r["full"] / r["bare"] for r in runs),
        "overheads": [r["full"] / r["bare"] for r in runs],
        "runs": runs,
    }


def make_rows(results: dict[str, dict[str, Any]]) -> list[Row]:
    rows: list[Row] = []
    for name, r in results.items():
        ok = sum(r["success"].values())
        for layout, f in r["layouts"].items():
            pairs = "/".join(f"{x:.2f}" for x in f["overheads"])
            rows.append(
                Row(
                    figure=f"{name}: wall ms per simulated s, full system, {layout}",
                    value=1e3 * f["full_wall_per_sim_s"],
                    unit="ms",
                    baseline="bare mj_step, same set-points",
                    baseline_value=1e3 * f["bare_wall_per_sim_s"],
                    target="< 2x",
                    met=f["overhead"] < 2.0,
                    note=f"median of {len(f['overheads'])} pairs' ratios: {pairs}",
                    paired_ratio=f["overhead"],
                )
            )
        first = r["layouts"][r["real_time_layout"]]
        rows += [
            Row(
                figure=f"{name}: real-time factor, fast mode, {r['real_time_layout']}",
                value=1.0 / first["full_wall_per_sim_s"],
                unit="x",
                baseline="bare at rest",
                baseline_value=1.0 / r["rest_wall_per_sim_s"],
            ),
            Row(
                figure=f"{name}: CPU of an idle world in real time, % of a core",
                value=100 * r["idle_real_time_cpu"],
                unit="%",
                baseline="bare stepping at rest, real time",
                baseline_value=100 * r["rest_wall_per_sim_s"],
            ),
            Row(
                figure=f"{name}: real-time factor, real-time mode, {r['real_time_layout']}",
                value=r["real_time_factor"],
                unit="x",
                target=">= 0.98, no slip",
                met=r["real_time_factor"] >= 0.98 and r["real_time_slips"] == 0,
            ),
            Row(
                figure=f"{name}: pick-and-place success",
                value=ok,
                unit=f"of {len(r['success'])}",
                target="all",
                met=ok == len(r["success"]),
            ),
            Row(
                figure=f"{name}: stop-to-halt, worst (simulated)",
                value=1e3 * max(r["stop_to_halt_s"]),
                unit="ms",
                target="< 500 ms",
                met=max(r["stop_to_halt_s"]) < 0.5,
            ),
        ]
    return rows


def print_details(results: dict[str, dict[str, Any]]) -> None:
    for name, r in results.items():
        halts = ", ".join(f"{1e3 * h:.0f}" for h in r["stop_to_halt_s"])
        print(
            f"{name}: success {r['success']}; stop-to-halt ms [{halts}]; "
            f".rrd {r['rrd_bytes'] / 1e6:.1f} MB"
        )
        for layout, f in r["layouts"].items():
            print(
                f"  {layout}: {f['sim_s']:.1f} s simulated; CPU ms per simulated s: this "
                f"process {1e3 * f['cpu_per_sim_s']:.1f}, client process "
                f"{1e3 * f['client_cpu_per_sim_s']:.1f}"
            )


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="short smoke run")
    parser.add_argument("--json", type=Path, metavar="FILE", help="also write results as JSON")
    parser.add_argument("--scenario", action="append", choices=sorted(WORKLOADS))
    parser.add_argument(
        "--repeat", type=int, metavar="N", help="fast runs (and replays) per scenario (9; quick: 1)"
    )
    parser.add_argument(
        "--layout",
        action="append",
        choices=LAYOUTS,
        help="where the client and the router run (repeatable; the first is the headline; "
        "default: deployed and in-process)",
    )
    parser.add_argument("--in-process", action="store_true", help="the single-process layout only")
    parser.add_argument(
        "--sensor-period",
        type=float,
        default=0.5,
        metavar="S",
        help="the workload reads every sensor every S simulated seconds (0: never; default 0.5)",
    )
    hidden = argparse.SUPPRESS
    parser.add_argument("--role", choices=("client", "router"), help=hidden)
    parser.add_argument("--listen", help=hidden)
    parser.add_argument("--connect", help=hidden)
    parser.add_argument("--mesh", help=hidden)
    parser.add_argument("--picks", type=int, help=hidden)
    args = parser.parse_args(argv)
    if args.role == "router":
        return child_router(args)
    if args.role == "client":
        args.scenario = args.scenario[0]
        return child_client(args)
    repeat = max(1, args.repeat or (1 if args.quick else 9))
    layouts = ["in-process"] if args.in_process else args.layout or ["deployed", "in-process"]
    info = machine_info(("mujoco", "rerun-sdk", "eclipse-zenoh", "placo"))
    conditions = {"load_start": load_average(), "calibration_ms_start": calibrate()}
    started = time.perf_counter()
    results: dict[str, dict[str, Any]] = {}
    with tempfile.TemporaryDirectory(prefix="skimesh-bench-sim-") as tmp:
        for name in args.scenario or sorted(WORKLOADS):
            print(f"{name}: measuring...", file=sys.stderr, flush=True)
            run = partial(measure, period=args.sensor_period)
            results[name] = anyio.run(run, name, args.quick, repeat, layouts, Path(tmp))
    conditions |= {"load_end": load_average(), "calibration_ms_end": calibrate()}
    rows = make_rows(results)
    print("machine: " + ", ".join(f"{k} {v}" for k, v in info.items()))
    print(
        f"run: {'quick' if args.quick else 'full'}, {time.perf_counter() - started:.0f} s; load "
        f"average {conditions['load_start']} at start, {conditions['load_end']} at end\n"
    )
    print(format_table(rows))
    print_details(results)
    if args.json is not None:
        doc = {"machine": info, "conditions": conditions, "rows": rows, "results": results}
        args.json.write_bytes(msgspec.json.format(msgspec.json.encode(doc)))
    return 0 if all(row.met is not False for row in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
