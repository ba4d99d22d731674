"""A snapshot's device states: captured by the simulation thread (copies), built when first
read, and then exactly the states of the snapshot's moment, whatever has moved since."""

from __future__ import annotations

from pathlib import Path

import pytest
from msgspec import Struct

from device_drivers.protocol import MoveJoints, SetDoor
from mujoco_sim import Plant
from mujoco_sim.control import Job
from scenario import load_scenario

pytestmark = pytest.mark.sim

MEAL = Path(__file__).resolve().parents[3] / "configs" / "scenarios" / "meal" / "scenario.toml"


def test_states_are_those_of_the_snapshots_moment_built_when_read() -> None:
    plant = Plant(load_scenario(MEAL))
    arm, oven = ("friend", "arm"), ("Microwave-1", "appliance")
    plant.run_batch(10, [])
    snapshot = plant.snapshot
    then = {key: ctrl.state() for key, ctrl in plant.controllers.items()}
    then = {key: state for key, state in then.items() if state is not None}
    captured = snapshot.states._captured  # type: ignore[attr-defined]
    assert not isinstance(captured[arm], Struct), "the arm's state is not built yet"

    moves = [Job(arm, MoveJoints({"elbow": 1.2}, duration=0.3)), Job(oven, SetDoor(open=True))]
    plant.run_batch(60, moves)
    assert plant.controllers[arm].state() != then[arm]  # the arm moved, the door opened
    assert plant.controllers[oven].state() != then[oven]

    assert set(snapshot.states) == set(then)
    assert dict(snapshot.states) == then  # built now, from what was copied then
    assert snapshot.states[arm] is snapshot.states[arm]  # built once
