"""The key space: every builder, and the validation of every name segment."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from meshlink import InvalidKeyError, KeySpace, check_name


def test_every_builder_produces_the_documented_key() -> None:
    k = KeySpace("lab")
    assert k.prefix == "skimesh/lab"
    assert k.wm_rpc() == "skimesh/lab/wm/rpc"
    assert k.wm_changes() == "skimesh/lab/wm/changes"
    assert k.wm_element("Robot-1") == "skimesh/lab/wm/elements/Robot-1"
    assert k.wm_elements() == "skimesh/lab/wm/elements/**"
    assert k.agent("robot_a") == "skimesh/lab/agents/robot_a"
    assert k.agents() == "skimesh/lab/agents/*"
    assert k.agent_skills("robot_a") == "skimesh/lab/agents/robot_a/skills"
    assert k.agents_skills() == "skimesh/lab/agents/*/skills"
    assert k.agent_rpc("robot_a") == "skimesh/lab/agents/robot_a/rpc"
    assert k.run_progress("robot_a", "run-7") == "skimesh/lab/agents/robot_a/runs/run-7/progress"
    assert k.runs_progress("robot_a") == "skimesh/lab/agents/robot_a/runs/*/progress"
    assert k.device_state("r1", "gripper") == "skimesh/lab/devices/r1/gripper/state"
    assert k.device_cmd("r1", "gripper") == "skimesh/lab/devices/r1/gripper/cmd"
    assert k.devices() == "skimesh/lab/devices/**"
    assert k.tasks_rpc() == "skimesh/lab/tasks/rpc"
    assert k.operator_rpc() == "skimesh/lab/operator/rpc"
    assert k.wm_query() == "skimesh/lab/wm/query"
    assert k.task_events("t.42") == "skimesh/lab/tasks/t.42/events"


def test_default_mesh() -> None:
    assert KeySpace().wm_rpc() == "skimesh/default/wm/rpc"


@pytest.mark.parametrize(
    ("name", "char"),
    [
        ("a/b", "/"),
        ("a*", "*"),
        ("**", "*"),
        ("$x", "$"),
        ("what?", "?"),
        ("x#1", "#"),
        ("a b", " "),
        ("tab\there", "\t"),
        ("new\nline", "\n"),
        ("café", "é"),
    ],
)
def test_bad_characters_are_named(name: str, char: str) -> None:
    with pytest.raises(InvalidKeyError) as info:
        check_name(name, "agent name")
    message = str(info.value)
    assert repr(char) in message
    assert f"position {name.index(char)}" in message
    assert message.startswith("agent name")


def test_empty_and_non_string_names_are_rejected() -> None:
    with pytest.raises(InvalidKeyError, match="is empty"):
        check_name("")
    with pytest.raises(InvalidKeyError, match="must be a str"):
        check_name(3)  # type: ignore[arg-type]


BUILDERS: list[Callable[[KeySpace, str], str]] = [
    KeySpace.wm_element,
    KeySpace.agent,
    KeySpace.agent_skills,
    KeySpace.agent_rpc,
    KeySpace.runs_progress,
    lambda k, bad: k.run_progress("ok", bad),
    lambda k, bad: k.run_progress(bad, "ok"),
    lambda k, bad: k.device_state(bad, "ok"),
    lambda k, bad: k.device_cmd("ok", bad),
    KeySpace.task_events,
]


@pytest.mark.parametrize("build", BUILDERS)
def test_every_builder_validates_its_segments(build: Callable[[KeySpace, str], str]) -> None:
    with pytest.raises(InvalidKeyError, match="'\\*'"):
        build(KeySpace(), "x*")


def test_mesh_name_is_validated() -> None:
    with pytest.raises(InvalidKeyError, match="mesh name"):
        KeySpace("a/b")


def test_name_of_agent_key() -> None:
    k = KeySpace("lab")
    assert k.name_of_agent_key(k.agent("robot_a")) == "robot_a"
    for bad in ["skimesh/other/agents/robot_a", "skimesh/lab/agents/", "skimesh/lab/agents/a/b"]:
        with pytest.raises(InvalidKeyError, match="not an agent key"):
            k.name_of_agent_key(bad)
