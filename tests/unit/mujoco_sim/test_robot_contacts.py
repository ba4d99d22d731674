"""Contacts between two robots' bodies are recorded for the whole run: none while the robots
stand apart, the first one (time, robots, bodies) once one base is put onto another."""

from __future__ import annotations

from pathlib import Path

from mujoco_sim import Plant
from scenario import load_scenario

SCENARIOS = Path(__file__).resolve().parents[3] / "configs" / "scenarios"


def test_robots_apart_touch_nothing_and_a_base_on_another_is_recorded() -> None:
    plant = Plant(load_scenario(SCENARIOS / "kitting" / "scenario.toml"))
    plant.run_batch(5, [])
    contacts = plant.robot_contacts
    assert contacts.ticks == 0 and not contacts.pairs and str(contacts.first or "") == ""
    m, d = plant.model, plant.data
    # r2's base where r1 stands: the slide joints hold world x and y (their ref is the pose)
    r1x, r1y = (float(d.qpos[m.joint(f"r1/base_{a}").qposadr[0]]) for a in "xy")
    d.qpos[m.joint("r2/base_x").qposadr[0]] = r1x + 0.1
    d.qpos[m.joint("r2/base_y").qposadr[0]] = r1y
    plant.run_batch(1, [])
    assert contacts.ticks >= 1
    assert contacts.pairs == {("r1", "r2")}
    first = contacts.first
    assert first is not None and set(first.robots) == {"r1", "r2"}
    assert all(b.split("/")[0] in ("r1", "r2") for b in first.bodies)
    assert first.time > 0 and " touched at t = " in str(first)
