"""The shared-space benchmark's measurement and command line (see the package docstring)."""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from collections.abc import Sequence
from pathlib import Path

import anyio
import msgspec

from benchmarks.common import ROOT, Row, Stats, format_table, machine_info, summarize
from device_drivers import BaseState, Pose2D, ProgressCallback
from meshlink import MeshConfig, open_mesh, run_router
from meshlink.testing import free_port
from scenario import load_scenario
from scenario.wm import scenario_ops
from skill_agent import Skill, SkillContext
from skill_agent.protocol import StartRun
from skill_agent.runtime import AgentCore, SkillEntry
from skill_agent.skills import Navigate
from wm_store import WmClient, ZenohTransport
from wm_store.ontology import Ontology
from wm_store.protocol import Op
from wm_store.server import WmStore, serve_store

__all__ = ["main", "measure"]

TARGET_MS = 5.0


class InstantBase:
    """A mobile base that is at its target as soon as it is told to go."""

    def __init__(self, name: str, pose: Pose2D) -> None:
        self._name, self.pose = name, pose

    @property
    def name(self) -> str:
        return self._name

    async def stop(self) -> None:
        return None

    async def state(self) -> BaseState:
        return BaseState(pose=self.pose, moving=False)

    async def go_to(
        self, target: Pose2D, *, speed: float = 0.5, progress: ProgressCallback | None = None
    ) -> None:
        self.pose = target

    async def set_velocity(
        self, vx: float, vy: float, wz: float, *, duration: float | None = None
    ) -> None:
        return None


class NavigateWithoutRoom(Navigate):
    """``navigate`` without the reservation: the baseline."""

    async def take_room(self, ctx: SkillContext) -> None:
        return None

    def leave_start(self, ctx: SkillContext) -> list[Op]:
        return []


class Result(msgspec.Struct, kw_only=True):
    with_room: Stats
    without: Stats
    added_ms: float
    """Median of (with - without) over the pairs."""


def _entry(skill: type[Skill]) -> SkillEntry:
    return SkillEntry(skill.description, skill, skill.__module__)


async def measure(drives: int) -> Result:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    config = MeshConfig(connect=(endpoint,), mesh="space-bench")
    scenario = load_scenario(ROOT / "configs" / "scenarios" / "kitting" / "scenario.toml")
    ontology = Ontology.default()
    store = await WmStore.open(ontology)
    async with anyio.create_task_group() as tg:
        await tg.start(run_router, [endpoint])
        async with open_mesh(config) as server_mesh:
            await tg.start(serve_store, server_mesh, store)
            async with (
                open_mesh(config) as mesh,
                WmClient.connect(ZenohTransport(mesh), author="bench") as wm,
            ):
                reply = await wm.transact(scenario_ops(scenario))
                ids = {ref[1:]: eid for ref, eid in reply.ids.items() if ref.startswith("$")}
                robot = next(r for r in scenario.robots if r.name == "r1")
                base = InstantBase("r1-base", Pose2D(robot.pose.x, robot.pose.y, robot.pose.yaw))
                cores = {
                    reserve: AgentCore(
                        name=f"r1-{'room' if reserve else 'plain'}",
                        wm=wm,
                        skills={"navigate": _entry(Navigate if reserve else NavigateWithoutRoom)},
                        devices={ids["r1-base"]: base},
                        robot=ids["r1"],
                    )
                    for reserve in (True, False)
                }
                for core in cores.values():
                    await tg.start(core.run)
                stations = [ids["Station-1"], ids["Station-2"]]
                times: dict[bool, list[float]] = {True: [], False: []}
                for i in range(2 * drives + 2):
                    reserve = (i // 2) % 2 == 0  # pairs: each mode drives there and back
                    goal = stations[i % 2]
                    start = time.perf_counter()
                    run = await cores[reserve].start(
                        StartRun(skill="navigate", params={"goal": goal})
                    )
                    result = await cores[reserve].wait(run.run_id)
                    elapsed = time.perf_counter() - start
                    if not result.success:
                        raise RuntimeError(f"navigate failed: {result.message}")
                    if i >= 2:  # the first drive leaves home: a warm-up
                        times[reserve].append(elapsed)
            tg.cancel_scope.cancel()
    n = min(len(times[True]), len(times[False]))
    added = statistics.median(a - b for a, b in zip(times[True][:n], times[False][:n], strict=True))
    return Result(
        with_room=summarize(times[True], 1000.0),
        without=summarize(times[False], 1000.0),
        added_ms=added * 1000.0,
    )


def rows(r: Result) -> list[Row]:
    return [
        Row(
            figure="navigate with a reservation, p50",
            value=r.with_room.p50,
            unit="ms",
            baseline="without",
            baseline_value=r.without.p50,
            target=f"+ < {TARGET_MS:g} ms",
            met=r.added_ms < TARGET_MS,
            note=f"added {r.added_ms:.2f} ms (median of pairs)",
        ),
        Row(
            figure="navigate with a reservation, p99",
            value=r.with_room.p99,
            unit="ms",
            baseline="without",
            baseline_value=r.without.p99,
        ),
    ]


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=sys.modules["benchmarks.space"].__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--quick", action="store_true", help="60 drives each way")
    parser.add_argument("--drives", type=int, default=0, help="drives each way (default 400)")
    parser.add_argument("--json", type=Path, help="also write the results as JSON")
    args = parser.parse_args(argv)
    drives = args.drives or (60 if args.quick else 400)
    info = machine_info(["eclipse-zenoh"])
    print(" ".join(f"{k}={v}" for k, v in info.items()), file=sys.stderr)
    result = anyio.run(measure, drives)
    print(format_table(rows(result)))
    if args.json:
        out = {"machine": info, "result": msgspec.to_builtins(result)}
        args.json.write_text(json.dumps(out, indent=1))
    return 0
