"""``task verify`` on shared space: two robots sent to one place that holds one robot, in
parallel branches, is reported; the same in a sequence, to two places, or to a place with room
for two is not."""

from __future__ import annotations

import pytest

from task_agent.protocol import TaskFile
from task_agent.verification import SceneView, verify
from tests.unit.task_agent.test_verify import World, call, par, problems, seq, world
from wm_store.protocol import UpdateElement
from wm_store.scene import apply_transaction


@pytest.fixture
def kitting() -> World:
    return world("kitting")


def test_two_robots_to_one_station_in_parallel_branches_is_reported(kitting: World) -> None:
    task = TaskFile(
        root=par(
            call("r1", "navigate", goal="Station-1"),
            seq(call("r2", "navigate", goal="Station-1")).root,
        )
    )
    found = problems(kitting, task)
    assert len(found) == 1
    _, kind, message = found[0]
    assert kind == "resource"
    assert "both send a robot to Station-1, which holds one: r2" in message
    assert "and r1" in message and "order them in a sequence" in message


def test_one_after_the_other_or_to_two_stations_is_fine(kitting: World) -> None:
    in_turn = seq(
        call("r1", "navigate", goal="Station-1"),
        call("r1", "navigate", goal="label:r1-home"),
        call("r2", "navigate", goal="Station-1"),
    )
    assert problems(kitting, in_turn) == []
    apart = TaskFile(
        root=par(call("r1", "navigate", goal="Station-1"), call("r2", "navigate", goal="Station-2"))
    )
    assert problems(kitting, apart) == []


def test_a_place_with_room_for_two_takes_both(kitting: World) -> None:
    state = kitting.view.state.copy()
    station = next(e.id for e in state.elements.values() if e.label == "Station-1")
    apply_transaction(
        state,
        kitting.view.ontology,
        [UpdateElement(id=station, properties={"robotCapacity": 2})],
        revision=state.revision + 1,
        now=2.0,
    )
    task = TaskFile(
        root=par(call("r1", "navigate", goal="Station-1"), call("r2", "navigate", goal="Station-1"))
    )
    view = SceneView(state, kitting.view.ontology)
    assert verify(task, view, kitting.agents) == []
