"""``skimesh task status|list|abort|watch`` and the exit codes 1 (failed) and 4 (aborted),
each command a subprocess, over real Zenoh on loopback.

The set-up is :mod:`tests.integration.test_tasks`'s (:func:`running_site`: a world-model
store, agents r1 and r2 with simulated outcomes, ``skimesh task-agent``), plus two agents of
this module's own: ``slow`` (its skills take 20x their duration: navigating takes 100 s, so a
task is still running while the commands look at it) and ``clumsy`` (its picks always fail).
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from typing import Any

import anyio
import pytest

from skill_agent.client import AgentClient
from task_agent import new_task_id

from .procs import Child
from .test_tasks import Site, add_robots, running_site

pytestmark = [pytest.mark.zenoh, pytest.mark.slow]


@pytest.fixture(scope="module")
def cli_site(module_router: str, tmp_path_factory: pytest.TempPathFactory) -> Iterator[Site]:
    with running_site(module_router, tmp_path_factory.mktemp("task-cli")) as site:
        agents = [site.spawn_agent("slow", time_scale=20.0), site.spawn_agent("clumsy", pick=0.0)]
        for name, child in zip(("slow", "clumsy"), agents, strict=True):
            child.wait_stderr(f"agent {name} ready")

        async def robots() -> None:
            async with site.connected() as (_, wm, _client):
                await add_robots(wm, ["slow", "clumsy"])

        anyio.run(robots)
        yield site
        for child in agents:  # (running_site stops them too, whatever happens)
            assert child.stop() == 0, f"{child.name} did not stop cleanly:\n{child.log()}"


def json_out(done: Any) -> Any:
    assert done.returncode == 0, done.stdout + done.stderr
    return json.loads(done.stdout)


def goal_ids(s: Site, kit: str, gear: str) -> str:
    """``contain(kit, gear)`` with element ids, as the task agent reports goals."""

    async def resolve() -> str:
        async with s.connected() as (_, wm, _client):
            k = wm.resolve_element(type="KitBox", label=kit)[0].id
            return f"contain({k}, {wm.resolve_element(type='Gear', label=gear)[0].id})"

    return anyio.run(resolve)


def test_detach_then_watch_status_list_and_abort(cli_site: Site) -> None:
    s, task_id = cli_site, new_task_id()
    goal = goal_ids(s, "kit-slow", "gear-1")
    submitted = s.skimesh(
        "task", "submit", "--goal", "contain(kit-slow, gear-1)", "--task-id", task_id, "--detach"
    )
    assert submitted.returncode == 0, submitted.stderr
    assert submitted.stdout.strip() == task_id
    watch = ["-m", "skimesh", "task", "watch", task_id, "--json", *s.flags()]
    watcher = Child(watch, name="task watch")
    try:
        info = json_out(s.skimesh("task", "status", task_id, "--json"))
        assert (info["task_id"], info["outcome"]) == (task_id, "running"), info
        assert info["goal"] == goal and info["finished_at"] == 0
        active = json_out(s.skimesh("task", "list", "--active", "--json"))
        assert task_id in [t["task_id"] for t in active]
        assert all(t["outcome"] == "running" for t in active)

        aborted = s.skimesh("task", "abort", task_id, "--reason", "cli test", "--json")
        reply = json_out(aborted)
        assert (reply["task_id"], reply["outcome"]) == (task_id, "aborted"), reply
        assert reply["reply"] == f"task {task_id}: aborted"
        assert reply["message"] == "cli test" and reply["steps_run"] == 1  # mid-navigation

        last = watcher.expect(lambda event: event["event"] == "TaskFinished", timeout=60)
        assert (last["outcome"], last["message"]) == ("aborted", "cli test")
        assert watcher.proc.wait(timeout=30) == 4, watcher.log()  # Exit.ABORTED
    finally:
        watcher.stop()
    after = json_out(s.skimesh("task", "list", "--json"))
    assert {t["task_id"]: t["outcome"] for t in after}[task_id] == "aborted"
    again = s.skimesh("task", "abort", task_id)
    assert again.returncode == 0 and "already ended: aborted" in again.stdout, again.stderr

    async def runs_of_slow() -> list[Any]:
        async with s.connected() as (mesh, _wm, _client):
            return list(await AgentClient(mesh, "slow").runs(active_only=False))

    (run,) = anyio.run(runs_of_slow)  # the abort stopped the robot's one run
    assert run.skill == "navigate" and run.result is not None
    assert run.result.reason == "preempted", run


def test_a_failed_task_exits_1_from_submit_and_watch(cli_site: Site) -> None:
    s, task_id = cli_site, new_task_id()
    failed = s.skimesh(
        "task",
        "submit",
        "--goal",
        "contain(kit-clumsy, gear-2)",
        "--max-replans",
        "0",
        "--task-id",
        task_id,
    )
    assert failed.returncode == 1, failed.stdout + failed.stderr
    lines = failed.stdout.splitlines()
    assert any(" clumsy " in line and "pick" in line and "FAILED (execution)" in line
               for line in lines), lines  # fmt: skip
    summary = next(line for line in lines if line.startswith(f"task {task_id} failed in "))
    assert "0 replans" in summary
    assert any("(no replan left of 0)" in line for line in lines), lines
    watched = s.skimesh("task", "watch", task_id, "--json")  # the task has ended already
    assert watched.returncode == 1, watched.stdout + watched.stderr
    last = json.loads(watched.stdout.splitlines()[-1])
    assert (last["event"], last["outcome"]) == ("TaskFinished", "failed")
    assert "pick on clumsy failed (execution)" in last["message"]
    info = json_out(s.skimesh("task", "status", task_id, "--json"))
    assert info["outcome"] == "failed" and info["replans"] == 0
