"""Agents, their machines, devices and skill descriptions, read from the world model."""

from __future__ import annotations

import msgspec
import pytest

from task_agent import DiscoveryError
from task_agent.discovery import AgentInfo, agents_from_view, decode_description
from tests.assets.planning import NAVIGATE, PICK, PLACE, apply_ops, kitting_scene
from wm_store.protocol import AddElement, Element, Relation, UpdateElement


def test_agents_with_robot_devices_and_skills() -> None:
    scene = kitting_scene(2, 2)
    agents = agents_from_view(scene.view)
    assert [a.name for a in agents] == ["r1", "r2"]
    r1 = agents[0]
    assert r1.robot == scene.robots[0]
    assert r1.devices == ("Arm-1", "Camera-1", "Gripper-1", "MobileBase-1")
    assert r1.hardware == (scene.robots[0], *r1.devices)
    assert r1.skills == tuple(sorted((NAVIGATE, PICK, PLACE), key=lambda s: s.name))
    assert r1.skill("pick") == PICK
    assert r1.skill("fly") is None
    assert r1.available and not r1.problems
    assert r1.id.startswith("RobotAgent-")


def test_devices_are_found_through_nested_has_a() -> None:
    scene = kitting_scene(1, 1)
    apply_ops(
        scene,
        [AddElement(type="Camera", label="wrist cam", relations=[Relation("Arm-1", "hasA", "$")])],
    )
    (agent,) = agents_from_view(scene.view)
    assert agent.devices == ("Arm-1", "Camera-1", "Camera-2", "Gripper-1", "MobileBase-1")


def test_availability_and_liveliness() -> None:
    scene = kitting_scene(2, 1)
    r1 = next(e for e in scene.view.resolve_element(type="Agent") if e.label == "r1")
    apply_ops(scene, [UpdateElement(id=r1.id, properties={"available": False})])
    assert [a.name for a in agents_from_view(scene.view)] == ["r2"]
    every = agents_from_view(scene.view, include_unavailable=True)
    assert [(a.name, a.available) for a in every] == [("r1", False), ("r2", True)]
    assert agents_from_view(scene.view, alive={"r1"}) == []


def test_unreadable_descriptions_are_reported_not_fatal() -> None:
    scene = kitting_scene(1, 1)
    skills = [r.object for r in scene.view.query_relation(predicate="hasSkill")]
    pick = next(s for s in skills if scene.view.get_element(s).label == "pick")
    place = next(s for s in skills if scene.view.get_element(s).label == "place")
    navigate = next(s for s in skills if scene.view.get_element(s).label == "navigate")
    apply_ops(
        scene,
        [
            UpdateElement(id=pick, properties={"description": '{"name": 3}'}),
            UpdateElement(id=place, remove=["description"]),
            UpdateElement(
                id=navigate, properties={"description": msgspec.json.encode(PICK).decode()}
            ),
        ],
    )
    (agent,) = agents_from_view(scene.view)
    assert agent.skills == ()
    text = " | ".join(agent.problems)
    assert "unreadable description" in text
    assert "has no description" in text
    assert "differs from its description's name 'pick'" in text


def test_decode_description() -> None:
    element = Element(
        id="Skill-1",
        type="Skill",
        label="pick",
        properties={"description": msgspec.json.encode(PICK).decode()},
    )
    assert decode_description(element) == PICK
    with pytest.raises(DiscoveryError, match="has no description"):
        decode_description(Element(id="Skill-2", type="Skill", label="x"))


def test_agent_info_round_trips() -> None:
    info = AgentInfo(name="r1", robot="Robot-1", devices=("Gripper-1",), skills=(PICK,))
    assert msgspec.json.decode(msgspec.json.encode(info), type=AgentInfo) == info
