"""A partner's service driven by a skill through skill_agent.external: the service side of the
goal / feedback / cancel protocol, as a foreign program would write it.

Run it with ``python docs/examples/partner_service.py --connect tcp/127.0.0.1:7447``; the agent
config's ``[[services]]`` entry with ``service = "partner/door"`` turns it into a skill.
"""

from __future__ import annotations

import argparse

import anyio

from meshlink import Answer, IncomingQuery, Mesh, MeshConfig, open_mesh
from skill_agent.external import (
    CancelAck,
    Feedback,
    GoalAccepted,
    Outcome,
    ServiceKeys,
    decode_service_request,
    encode,
)


async def serve_partner(mesh: Mesh, service: str = "partner/door", steps: int = 5) -> None:
    keys, goals = ServiceKeys(mesh.keys.prefix, service), dict[str, anyio.CancelScope]()

    async def work(goal_id: str) -> None:
        with anyio.CancelScope() as goals[goal_id]:
            for i in range(steps):
                feedback = Feedback(
                    goal_id=goal_id, message=f"step {i + 1}/{steps}", fraction=i / steps
                )
                mesh.put(keys.feedback(goal_id), encode(feedback))
                await anyio.sleep(0.05)
            mesh.put(keys.feedback(goal_id), encode(Outcome(goal_id=goal_id, success=True)))
        if goals.pop(goal_id).cancelled_caught:
            outcome = Outcome(goal_id=goal_id, success=False, message="cancelled")
            mesh.put(keys.feedback(goal_id), encode(outcome))

    async def on_goal(query: IncomingQuery) -> list[Answer]:
        goal = decode_service_request(query.payload or b"")
        tg.start_soon(work, goal.goal_id)
        return [Answer(keys.goal(), encode(GoalAccepted(goal_id=goal.goal_id)))]

    async def on_cancel(query: IncomingQuery) -> list[Answer]:
        goal_id = decode_service_request(query.payload or b"").goal_id
        scope = goals.get(goal_id)
        if scope is not None:
            scope.cancel()
        return [Answer(keys.cancel(), encode(CancelAck(goal_id=goal_id, known=scope is not None)))]

    async with anyio.create_task_group() as tg:
        await tg.start(mesh.serve, keys.goal(), on_goal)
        await tg.start(mesh.serve, keys.cancel(), on_cancel)
        with mesh.declare_token(keys.alive()):
            await anyio.sleep_forever()


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--connect", default="tcp/127.0.0.1:7447")
    parser.add_argument("--mesh", default="default")
    args = parser.parse_args()

    async def main() -> None:
        async with open_mesh(MeshConfig(connect=(args.connect,), mesh=args.mesh)) as mesh:
            await serve_partner(mesh)

    anyio.run(main)
