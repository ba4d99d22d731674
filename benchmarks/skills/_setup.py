"""The skill benchmark's plan (counts and durations), the agent it runs and its child processes
(``python -m benchmarks.skills --role store|agent``)."""

from __future__ import annotations

import argparse

import anyio
import msgspec
import zenoh

from benchmarks.common import (
    ROOT,
    emit,
    stdin_lines,
)
from meshlink import Answer, IncomingQuery, MeshConfig, open_mesh
from meshlink.testing import undeclare
from skill_agent import Skill, SkillContext
from skill_agent.protocol import SkillDescription
from skill_agent.runtime import AgentConfig, load_config
from skill_agent.server import run_agent
from skimesh.runtime import run_service
from wm_store.ontology import Ontology
from wm_store.server import StoreConfig, WmStore, serve_store

BREAKDOWN = {
    "request": "start sent -> agent's first event (request delivery, dispatch, start)",
    "agent": "first event -> result, in the agent (lifecycle, 7 events published)",
    "result": "result stamped -> result in the client's loop (publication delivery)",
}
PAYLOAD = 200  # bytes of the baseline replies (a StartRun / RunStarted pair is ~100-200 bytes)
AGENT = "noop"
CALLERS = 8
IDLE_SKILL = "benchmarks.skills:Idle"


class Idle(Skill):
    """Waits in ``execute`` until stopped; nothing to make safe. What the stop figure stops."""

    description = SkillDescription(name="idle", doc="Waits until stopped.", duration=0.0)

    async def execute(self, ctx: SkillContext) -> None:
        await anyio.sleep_forever()


class Plan(msgspec.Struct, frozen=True):
    runs: int
    per_run_subscription_runs: int
    warmup: int
    raw_calls: int
    throughput_seconds: float
    stops: int


FULL = Plan(
    runs=2000,
    per_run_subscription_runs=500,
    warmup=200,
    raw_calls=2000,
    throughput_seconds=5.0,
    stops=1000,
)
QUICK = Plan(
    runs=300,
    per_run_subscription_runs=100,
    warmup=50,
    raw_calls=300,
    throughput_seconds=1.5,
    stops=150,
)


def agent_config() -> AgentConfig:
    """``configs/agents/noop.toml`` with :class:`Idle` added to its skills."""
    config = load_config(ROOT / "configs" / "agents" / f"{AGENT}.toml")
    skills = msgspec.structs.replace(config.skills, paths=[*config.skills.paths, IDLE_SKILL])
    return msgspec.structs.replace(config, skills=skills)


def echo_keys(mesh: str) -> tuple[str, str]:
    base = f"skimesh/{mesh}/bench"
    return f"{base}/skills-raw", f"{base}/skills-bridge"


def child_store(args: argparse.Namespace) -> int:
    async def main() -> int:
        store = await WmStore.open(Ontology.default(), StoreConfig(durability="none"))
        config = MeshConfig(connect=(args.connect,), mesh=args.mesh)
        async with open_mesh(config) as mesh, anyio.create_task_group() as tg:
            await tg.start(serve_store, mesh, store)
            emit({"ready": True})
            async for _ in stdin_lines():
                pass
            tg.cancel_scope.cancel()
        return 0

    return run_service(main)


def child_agent(args: argparse.Namespace) -> int:
    """The no-op agent, plus a raw Zenoh echo queryable and a meshlink echo on its session."""
    raw_key, bridge_key = echo_keys(args.mesh)
    reply = bytes(PAYLOAD)

    def on_query(query: zenoh.Query) -> None:  # zenoh's thread for this queryable
        with query:
            query.reply(query.key_expr, reply)

    async def bridge_echo(_query: IncomingQuery) -> list[Answer]:
        return [Answer(key=bridge_key, payload=reply)]

    async def main() -> int:
        config = agent_config()
        mesh_config = MeshConfig(connect=(args.connect,), mesh=args.mesh)
        async with open_mesh(mesh_config) as mesh, anyio.create_task_group() as tg:
            queryable = mesh.session.declare_queryable(raw_key, on_query)
            try:
                await tg.start(mesh.serve, bridge_key, bridge_echo)
                await tg.start(run_agent, mesh, config)
                emit({"ready": True})
                async for _ in stdin_lines():
                    pass
            finally:
                undeclare(queryable)
                tg.cancel_scope.cancel()
        return 0

    return run_service(main)
