"""A stalled subscriber does not stop the store, the agent or the task service.

The services run in this process on one Zenoh session (:mod:`tests.integration.services`,
router on loopback). A raw Zenoh subscriber in another session follows ``wm/changes``, the
agent's ``events`` and ``runs/*/progress``, every ``tasks/*/events`` and a bulk key; its
callback blocks Zenoh's receive thread for :data:`STALL` seconds. Meanwhile the test drives
traffic that makes every service publish (transactions, skill runs, task submissions of a
one-call task file) and pushes bulk samples through the services' session, so the link from
that session to the router fills and publications with congestion control BLOCK must wait
(asserted: the session's sender had a backlog).

What it catches: any Zenoh call made on the event loop that waits for the congested link: a
BLOCK ``put`` outside meshlink's sender, a query sent (``session.get``), a reply. The loop would
then stop until the subscriber is released: the heartbeat of
:func:`meshlink.testing.watch_loop` comes back late (more than :data:`GAP`), the
``blocking_detector`` fixture reports the loop step that held it, and the requests, which the
services answer on that loop, take longer than :data:`BOUND`. Once released, the subscriber
must receive every change (revisions without a gap), every run's result and every task's end,
all successful, and every bulk sample.

The timed requests go from the services' own session to its own queryables
(``Locality.SESSION_LOCAL``): a reply to another session crosses the congested link and the
router, behind the samples queued there (Zenoh's head-of-line blocking, whatever the services
do), so its delay measures the link, not the services. Requests from a second session, sent
during the stall too, must only be answered.
"""

from __future__ import annotations

import threading
import time
from collections import defaultdict
from pathlib import Path
from typing import TYPE_CHECKING, Any

import anyio
import anyio.to_thread
import msgspec
import pytest
import zenoh

from meshlink import KeySpace, Mesh, MeshConfig, open_mesh, to_zenoh_config
from meshlink.rpc import Decoder, encode
from meshlink.testing import call0, running_router, undeclare, watch_loop
from skill_agent import protocol as agent
from task_agent import protocol as task
from wm_store import protocol as wm

from .services import AGENT, Services, running_services

if TYPE_CHECKING:
    from tests.conftest import MeshConfigFactory as MakeConfig
    from tests.conftest import SlowSteps

pytestmark = [pytest.mark.zenoh, pytest.mark.anyio]

STALL = 2.0
"""Seconds the subscriber's callback blocks Zenoh's receive thread."""
BOUND = 1.0
"""Seconds a request may take while the subscriber stalls: half the stall, so a request the
stall held up fails, while a busy 2-core machine (the whole suite running) does not."""
GAP = 0.25
"""Seconds the event loop may come back late to the heartbeat."""
BULK = 64 * 1024
BULK_LIMIT = 1500
"""Bulk samples at most: the traffic is bounded whatever the link does."""
CYCLES = 20
"""Rounds of traffic at most (each: a transaction, a run, a task, and reads)."""
TASK_FILE = 'name = "one noop"\n[root]\nblock = "call"\nagent = "r1"\nskill = "noop"\n'


class StalledSubscriber:
    """A raw Zenoh session subscribed to ``keys``; its callback blocks until :attr:`release`
    is set (or ``4 * STALL`` passed). Records each sample but the bulk ones (only counted)."""

    def __init__(self, config: MeshConfig, keys: list[str], bulk_key: str) -> None:
        self.release = threading.Event()
        self.samples: list[tuple[str, bytes]] = []
        self.bulk = 0
        self._bulk_key = bulk_key
        self._session = zenoh.open(to_zenoh_config(config))
        self._subscribers = [
            self._session.declare_subscriber(
                key, zenoh.handlers.Callback(self._on_sample, lambda: None, indirect=False)
            )
            for key in [*keys, bulk_key]
        ]

    def _on_sample(self, sample: zenoh.Sample) -> None:  # Zenoh's receive thread: stalls it
        key = str(sample.key_expr)
        if key == self._bulk_key:
            self.bulk += 1
        else:
            self.samples.append((key, sample.payload.to_bytes()))
        self.release.wait(STALL * 4)

    def received(self, part: str) -> list[bytes]:
        """The payloads received on keys containing ``part``, in order."""
        return [payload for key, payload in list(self.samples) if part in key]

    def close(self) -> None:
        self.release.set()
        for subscriber in self._subscribers:
            undeclare(subscriber)
        call0(self._session.close)


def local_request(session: zenoh.Session, key: str, payload: bytes) -> tuple[bytes, bool, float]:
    """One request to a queryable of ``session`` itself (a worker thread waits for it):
    ``(reply payload, ok, seconds)``."""
    start = time.perf_counter()
    replies = list(
        session.get(
            key,
            payload=payload,
            allowed_destination=zenoh.Locality.SESSION_LOCAL,
            timeout=BOUND * 4,
        )
    )
    took = time.perf_counter() - start
    assert len(replies) == 1, f"{len(replies)} replies from {key} after {took:.2f} s"
    ok = replies[0].ok
    if ok is not None:
        return ok.payload.to_bytes(), True, took
    err = replies[0].err
    assert err is not None
    return err.payload.to_bytes(), False, took


class Traffic:
    """Requests that make the services publish, each timed."""

    def __init__(self, services: Services) -> None:
        self.session = services.mesh.session
        self.keys: KeySpace = services.mesh.keys
        self.took: dict[str, list[float]] = defaultdict(list)
        self.runs: list[str] = []
        self.tasks: list[str] = []

    async def request(self, what: str, key: str, request: object, replies: Any) -> Any:
        payload, ok, took = await anyio.to_thread.run_sync(
            local_request, self.session, key, encode(request)
        )
        self.took[what].append(took)
        reply = Decoder[Any](replies).decode(payload)
        assert ok, f"{what}: {reply!r}"
        return reply

    async def cycle(self, i: int) -> None:
        keys = self.keys
        add = wm.AddElement(type="Gear", label=f"gear-{i}")
        await self.request("transact", keys.wm_rpc(), wm.Transact(ops=[add]), wm.Reply)
        await self.request("wm info", keys.wm_query(), wm.Info(), wm.Reply)
        run = f"stall-{i}"
        start = agent.StartRun(skill="noop", run_id=run)
        await self.request("start run", keys.agent_rpc(AGENT), start, agent.AgentReply)
        self.runs.append(run)
        status = agent.RunStatus(run_id=run)
        await self.request("run status", keys.agent_rpc(AGENT), status, agent.AgentReply)
        submit = task.SubmitFile(text=TASK_FILE, task_id=run)
        await self.request("submit task", keys.tasks_rpc(), submit, task.TaskReply)
        self.tasks.append(run)
        await self.request("list tasks", keys.tasks_rpc(), task.ListTasks(), task.TaskReply)


async def remote_requests(client: Mesh, until: threading.Event) -> int:
    """Requests from another session, one after the other until ``until`` is set; each is
    answered (later than the local ones: its reply crosses the congested link). Returns how
    many were answered."""
    keys, answered = client.keys, 0
    requests = [
        (keys.wm_query(), wm.Info(), wm.Reply),
        (keys.agent_rpc(AGENT), agent.ListRuns(), agent.AgentReply),
        (keys.tasks_rpc(), task.ListTasks(), task.TaskReply),
    ]
    while not until.is_set():
        key, request, replies = requests[answered % len(requests)]
        reply = await client.request(key, encode(request), timeout=STALL * 4)
        Decoder[Any](replies).decode(reply)
        answered += 1
    return answered


PATIENT_LINKS = """{ transport: { link: { tx: { queue: { congestion_control: {
    block: { wait_before_close: 60000000 } } } } } } }"""
"""Zenoh closes a link on which a BLOCK message waited more than ``wait_before_close``
(default 5 s) and what was queued on it is lost. The stall itself is shorter, but on a loaded
machine the backlog behind it can take longer to drain; the test is about the services, not
about that threshold, so its router and sessions wait a minute before they give up a link."""


async def test_a_stalled_subscriber_does_not_stop_the_services(
    mesh_config: MakeConfig, blocking_detector: SlowSteps, tmp_path: Path
) -> None:
    patient = tmp_path / "patient-links.json5"
    patient.write_text(PATIENT_LINKS)
    with running_router(config_file=str(patient)) as endpoint:
        config = msgspec.structs.replace(mesh_config(endpoint), config_file=str(patient))
        await stall_and_release(config, blocking_detector, tmp_path)


async def stall_and_release(
    config: MeshConfig, blocking_detector: SlowSteps, tmp_path: Path
) -> None:
    async with (
        running_services(config, tmp_path / "wm", devices=False) as services,
        open_mesh(config) as client,
    ):
        mesh, keys = services.mesh, services.mesh.keys
        bulk_key = f"{keys.prefix}/test/bulk"
        followed = [
            keys.wm_changes(),
            keys.agent_events(AGENT),
            keys.runs_progress(AGENT),
            f"{keys.prefix}/tasks/*/events",
        ]
        stalled = StalledSubscriber(config, followed, bulk_key)
        traffic = Traffic(services)
        try:
            await mesh.get(bulk_key, timeout=1.0)  # one round trip: the router knows them
            first_revision = services.store.revision + 1
            reports_before = len(blocking_detector.reports)
            sent, backlog = 0, 0

            async def bulk() -> None:
                nonlocal sent, backlog
                with mesh.publisher(bulk_key) as publisher:
                    while not stalled.release.is_set():
                        if sent < BULK_LIMIT:
                            publisher.put(bytes(BULK))
                            sent += 1
                        backlog = max(backlog, mesh.statistics().publications_pending)
                        await anyio.sleep(0 if sent < BULK_LIMIT else 0.01)

            remote_answered: list[int] = []

            async def remote() -> None:
                remote_answered.append(await remote_requests(client, stalled.release))

            timer = threading.Timer(STALL, stalled.release.set)
            async with watch_loop(0.005) as watch:
                async with anyio.create_task_group() as tg:
                    timer.start()
                    tg.start_soon(bulk)
                    tg.start_soon(remote)
                    for i in range(CYCLES):
                        if stalled.release.is_set():
                            break
                        await traffic.cycle(i)
                        await anyio.sleep(STALL / CYCLES / 2)  # spread over the stall
                await anyio.sleep(0.05)  # the heartbeat records the last gap
                max_gap, ticks = watch.max_gap, watch.ticks
            timer.cancel()
            stalled.release.set()
            in_stall = blocking_detector.reports[reports_before:]

            assert backlog > 0, "the link never congested: the test proves nothing"
            assert in_stall == [], in_stall
            assert max_gap < GAP, f"the loop was blocked for {max_gap * 1000:.0f} ms"
            assert ticks > 50
            slow = {what: max(t) for what, t in traffic.took.items() if max(t) >= BOUND}
            assert slow == {}, f"requests slower than {BOUND} s while stalled: {slow}"
            assert len(traffic.runs) >= 3, "too little traffic while the subscriber stalled"
            assert remote_answered and remote_answered[0] > 0

            # Released: everything published while it stalled arrives, in order.
            with anyio.move_on_after(30):
                while not (  # noqa: ASYNC110 - filled by a Zenoh thread
                    stalled.bulk >= sent and delivered(stalled, traffic, services.store.revision)
                ):
                    await anyio.sleep(0.01)
            assert stalled.bulk >= sent and delivered(stalled, traffic, services.store.revision), (
                missing(stalled, traffic, services.store.revision, sent)
            )
            changes = [wm.decode_change(p).revision for p in stalled.received("/wm/changes")]
            assert changes[0] <= first_revision
            assert changes == list(range(changes[0], services.store.revision + 1))
            assert stalled.bulk == sent
        finally:
            stalled.close()


def results(stalled: StalledSubscriber) -> dict[str, agent.RunResult]:
    events = (agent.decode_event(p) for p in stalled.received("/runs/"))
    return {e.run_id: e for e in events if isinstance(e, agent.RunResult)}


def finished(stalled: StalledSubscriber) -> dict[str, task.TaskFinished]:
    events = (task.decode_event(p) for p in stalled.received("/tasks/"))
    return {e.task_id: e for e in events if isinstance(e, task.TaskFinished)}


def delivered(stalled: StalledSubscriber, traffic: Traffic, revision: int) -> bool:
    """Whether the subscriber has the last change, every run's result and every task's end
    (each of them successful, else the assertion says which)."""
    changes = stalled.received("/wm/changes")
    if not changes or wm.decode_change(changes[-1]).revision < revision:
        return False
    runs, tasks = results(stalled), finished(stalled)
    if not (set(traffic.runs) <= set(runs) and set(traffic.tasks) <= set(tasks)):
        return False
    failed_runs = [r for r in traffic.runs if not runs[r].success]
    failed_tasks = [t for t in traffic.tasks if tasks[t].outcome != "succeeded"]
    assert failed_runs == [] and failed_tasks == [], (failed_runs, failed_tasks)
    return True


def missing(stalled: StalledSubscriber, traffic: Traffic, revision: int, sent: int) -> str:
    """What the subscriber still lacks 30 s after its release (the failure message)."""
    changes = [wm.decode_change(p).revision for p in stalled.received("/wm/changes")]
    runs, tasks = results(stalled), finished(stalled)
    return (
        f"bulk {stalled.bulk}/{sent}; last change {changes[-1] if changes else None} of "
        f"{revision}; runs without a result {sorted(set(traffic.runs) - set(runs))}; "
        f"tasks without an end {sorted(set(traffic.tasks) - set(tasks))}"
    )
