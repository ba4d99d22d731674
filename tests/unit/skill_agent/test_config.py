"""Agent configs: the example files load, defaults, path resolution, and errors that name the
file and the field."""

from __future__ import annotations

from pathlib import Path

import pytest

from skill_agent import SkillError, SkillLoadError
from skill_agent.protocol import ParamSpec, PropertyCond, SkillDescription
from skill_agent.runtime import AgentConfig, load_config, parse_config
from skimesh.commands.agent import parse_params, scenario_config_path
from wm_store.protocol import Position

ROOT = Path(__file__).resolve().parents[3]


@pytest.mark.parametrize("path", sorted((ROOT / "configs" / "agents").glob("*.toml")), ids=str)
def test_example_configs_load(path: Path) -> None:
    config = load_config(path)
    assert config.name == path.stem
    for ref in config.skills.paths:
        if ".py" in ref:
            assert Path(ref.partition(":")[0]).is_file(), "file references resolve to real files"


def test_minimal_config_and_defaults() -> None:
    config = parse_config('name = "r1"')
    assert config == AgentConfig(name="r1")
    assert config.robot_label == "r1"
    assert config.robot.type == "Robot" and config.agent_type == "RobotAgent"
    assert not config.simulation.enabled and config.preempt_timeout == 5.0


def test_full_config(tmp_path: Path) -> None:
    (tmp_path / "cfg").mkdir()
    text = """
name = "r1"
conditions = ["my.conds"]
ontology = ["extra.ttl"]
event_log = "logs/events.jsonl"

[robot]
type = "MobileManipulator"
label = "robot-1"
properties = { mass = 40.0 }

[[devices]]
type = "Gripper"
label = "g"
properties = { graspWidth = 0.08 }

[skills]
paths = ["pkg.mod:Pick", "pkg.other", "skills/place.py:Place", "/abs/file.py"]
entry_points = ["noop"]

[simulation]
enabled = true
probabilities = { pick = 0.5 }
default = 0.9
seed = 3
time_scale = 0.1

[sensing]
max_age = 2.5

[[services]]
service = "partner/door"
[services.description]
name = "open_door"
post = [{ cond = "PropertyCond", param = "door", property = "doorOpen", value = true }]
"""
    path = tmp_path / "cfg" / "r1.toml"
    path.write_text(text)
    config = load_config(path)
    base = (tmp_path / "cfg").resolve()
    assert config.skills.paths == [
        "pkg.mod:Pick",
        "pkg.other",
        f"{base}/skills/place.py:Place",
        "/abs/file.py",
    ]
    assert config.ontology == [f"{base}/extra.ttl"]
    assert config.event_log == f"{base}/logs/events.jsonl"
    assert config.devices[0].properties == {"graspWidth": 0.08}
    assert config.simulation.probabilities == {"pick": 0.5} and config.simulation.seed == 3
    assert config.sensing.max_age == 2.5
    post = config.services[0].description.post[0]
    assert isinstance(post, PropertyCond) and post.value is True


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ('name = "r1"\n[robot]\nlable = "x"', r"unknown field `lable` - at `\$.robot`"),
        (
            'name = "r1"\n[[devices]]\nlabel = "g"',
            r"missing required field `type` - at `\$.devices\[0\]`",
        ),
        (
            'name = "r1"\n[simulation]\nprobabilities = { pick = 1.5 }',
            r"<= 1.0 - at `\$.simulation.probabilities",
        ),
        ('name = "r1"\npreempt_timeout = -1', r"> 0.0 - at `\$.preempt_timeout`"),
        ('name = "r 1"', r"agent name 'r 1' contains ' '"),
        ("robot = 3", r"Expected `object`, got `int` - at `\$.robot`"),
        ("[robot]", r"missing required field `name`"),
        ('name = "r1"\nskills = ["a"]', r"Expected `object`, got `array` - at `\$.skills`"),
        (
            'name = "r1"\n[[devices]]\ntype="Gripper"\nlabel="g"\n'
            '[[devices]]\ntype="Arm"\nlabel="g"',
            "repeated: g",
        ),
        ('name = "r1"\n[robot', "not valid TOML"),
    ],
)
def test_errors_name_file_and_field(tmp_path: Path, text: str, expected: str) -> None:
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(SkillLoadError, match=expected) as info:
        load_config(path)
    assert str(info.value).startswith(str(path)), "the message starts with the file"


def test_missing_file() -> None:
    with pytest.raises(SkillLoadError, match=r"cannot read agent config 'nope\.toml'"):
        load_config("nope.toml")


def test_probabilities_must_name_loaded_skills() -> None:
    config = parse_config('name = "r1"\n[simulation]\nprobabilities = { pik = 0.5 }')
    with pytest.raises(SkillLoadError, match=r"names skill 'pik'.*did you mean 'pick'"):
        config.check_skill_names(["place", "pick"])
    parse_config('name = "r1"\n[simulation]\nprobabilities = { pick = 0.5 }').check_skill_names(
        ["pick"]
    )


def test_scenario_configs_map_to_their_path() -> None:
    assert scenario_config_path("kitting", "r2").parts[-2:] == ("kitting", "r2.toml")
    with pytest.raises(FileNotFoundError, match=r"scenarios/nope/scenario\.toml"):
        scenario_config_path("nope", "r1")


def test_command_line_parameters_follow_the_declared_types() -> None:
    desc = SkillDescription(
        name="s",
        parameters=[
            ParamSpec(name="t", type="float"),
            ParamSpec(name="n", type="int"),
            ParamSpec(name="b", type="bool"),
            ParamSpec(name="part", type="Gear"),
            ParamSpec(name="p", type="Position"),
            ParamSpec(name="anything", type="any"),
        ],
    )
    got = parse_params(
        ["t=1", "n=2", "b=yes", "part=Gear-1", 'p={"x": 1, "y": 2, "z": 3}', "anything=[1, 2]"],
        desc,
    )
    assert got == {
        "t": 1.0,
        "n": 2,
        "b": True,
        "part": "Gear-1",
        "p": Position(1.0, 2.0, 3.0),
        "anything": [1, 2],
    }
    assert parse_params(["anything=plain words", "extra=3"], desc) == {
        "anything": "plain words",
        "extra": 3,
    }, "not JSON: a string; unknown names pass through (the agent names the closest)"
    with pytest.raises(SkillError, match="parameter n: 'two' is no valid int"):
        parse_params(["n=two"], desc)
    with pytest.raises(SkillError, match="KEY=VALUE"):
        parse_params(["oops"], desc)
