"""Scenario files: the shipped ones load, bad ones fail with the file and the field path, and
placements chain frames correctly. Pure (no simulation) except the deck-site check."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from scenario import (
    RobotSpec,
    Scenario,
    ScenarioError,
    deck_point,
    footprints,
    load_scenario,
    parse_scenario,
    resolve_placements,
)

ROOT = Path(__file__).resolve().parents[3]
SCENARIOS = ROOT / "configs" / "scenarios"

MINIMAL = """
name = "mini"
goals = ["contain(Box-1, Gear-1)"]

[[robots]]
name = "r1"

[[furniture]]
type = "Table"
label = "Table-1"
pose = { x = 1.0, yaw = 1.5707963267948966 }
size = [0.6, 1.0, 0.7]

[[containers]]
type = "PartBox"
label = "Box-1"
parent = "Table-1"
pose = { x = 0.1 }
size = [0.2, 0.3, 0.05]

[[parts]]
type = "Gear"
label = "Gear-1"
parent = "Box-1"
pose = { y = 0.05 }
shape = "cylinder"
size = [0.02, 0.02]
"""


@pytest.mark.parametrize("name", ["kitting", "meal", "workshop", "kitting-panda"])
def test_shipped_scenarios_load(name: str) -> None:
    scenario = load_scenario(SCENARIOS / name / "scenario.toml")
    assert scenario.name == name
    assert scenario.source.endswith("scenario.toml")
    assert all(Path(path).is_absolute() for path in scenario.agents.values())
    placed = resolve_placements(scenario)
    assert set(placed) >= {p.label for p in scenario.parts}


def test_kitting_has_what_the_task_needs() -> None:
    s = load_scenario(SCENARIOS / "kitting" / "scenario.toml")
    assert len(s.robots) == 2
    assert len(s.parts) >= 8
    assert len({p.type for p in s.parts}) >= 3
    kits = [c for c in s.containers if c.type == "KitBox"]
    assert sorted(c.parent for c in kits) == ["r1", "r2"]
    assert len([f for f in s.furniture if f.type == "Station"]) == 2


def test_meal_has_microwave_platform_camera_and_tray() -> None:
    s = load_scenario(SCENARIOS / "meal" / "scenario.toml")
    assert [a.type for a in s.appliances] == ["Microwave"]
    kinds = {sensor.kind for sensor in s.sensors}
    assert kinds == {"camera", "platform"}
    assert {c.type for c in s.containers} >= {"MealBox", "Tray"}


def test_unknown_field_names_file_and_path() -> None:
    text = MINIMAL.replace('shape = "cylinder"', 'shape = "cylinder"\ncolour = "red"')
    with pytest.raises(ScenarioError) as info:
        parse_scenario(text, source="bad.toml")
    assert str(info.value).startswith("bad.toml: ")
    assert "colour" in str(info.value)
    assert "$.parts[0]" in str(info.value)


def test_bad_value_names_the_field() -> None:
    with pytest.raises(ScenarioError, match=r"\$\.parts\[0\]\.mass"):
        parse_scenario(MINIMAL.replace("size = [0.02, 0.02]", "size = [0.02, 0.02]\nmass = -1"))


def test_size_must_match_shape() -> None:
    with pytest.raises(ScenarioError, match=r"cylinder needs size \[radius, height\]"):
        parse_scenario(MINIMAL.replace("size = [0.02, 0.02]", "size = [0.02, 0.02, 0.03]"))


def test_unknown_parent_suggests_the_close_label() -> None:
    with pytest.raises(ScenarioError, match=r"\$\.parts\[0\]\.parent.*did you mean 'Box-1'"):
        parse_scenario(MINIMAL.replace('parent = "Box-1"', 'parent = "Box-2"'))


def test_duplicate_label_is_refused() -> None:
    with pytest.raises(ScenarioError, match="'Table-1' is already used"):
        parse_scenario(MINIMAL.replace('label = "Box-1"', 'label = "Table-1"'))


def test_goal_syntax_and_labels_are_checked() -> None:
    with pytest.raises(ScenarioError, match=r"\$\.goals\[0\]"):
        parse_scenario(MINIMAL.replace("contain(Box-1, Gear-1)", "contain Box-1"))
    with pytest.raises(ScenarioError, match="unknown label 'Gear-9'"):
        parse_scenario(MINIMAL.replace("contain(Box-1, Gear-1)", "contain(Box-1, Gear-9)"))


def test_fixed_camera_needs_a_pose() -> None:
    text = MINIMAL + '\n[[sensors]]\nkind = "camera"\nlabel = "Camera-1"\n'
    with pytest.raises(ScenarioError, match="fixed camera needs position and look_at"):
        parse_scenario(text)


def test_bad_toml_and_missing_file() -> None:
    with pytest.raises(ScenarioError, match="not valid TOML"):
        parse_scenario("name = ", source="x.toml")
    with pytest.raises(ScenarioError, match="cannot read"):
        load_scenario(ROOT / "no" / "such.toml")


def test_placements_chain_parent_frames() -> None:
    scenario = parse_scenario(MINIMAL)
    placed = resolve_placements(scenario)
    box, gear = placed["Box-1"], placed["Gear-1"]
    # the table is turned by 90 degrees: its local x is the world y
    assert (box.x, box.y, box.z) == pytest.approx((1.0, 0.1, 0.7))
    assert box.yaw == pytest.approx(math.pi / 2)
    wall = scenario.containers[0].wall
    assert (gear.x, gear.y, gear.z) == pytest.approx((0.95, 0.1, 0.7 + wall))
    assert [f.label for f in footprints(scenario)] == ["Table-1"]


def test_containers_on_a_deck_ride_with_the_robot() -> None:
    text = MINIMAL.replace('parent = "Table-1"', 'parent = "r1"')
    placed = resolve_placements(parse_scenario(text))
    box = placed["Box-1"]
    assert box.robot == "r1"
    dx, _, dz = deck_point(RobotSpec(name="r1"))
    assert box.local == pytest.approx((dx + 0.1, 0.0, dz, 0.0))


@pytest.mark.sim
def test_deck_point_matches_the_model_site() -> None:
    import mujoco

    from mujoco_sim.models import build_robot
    from scenario import robot_layout

    spec = RobotSpec(name="r1", base_length=0.8, arm_mount_x=0.25, base_height=0.4)
    model = build_robot(spec).compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    site = data.site(robot_layout(spec).deck_site).xpos
    assert tuple(site) == pytest.approx(deck_point(spec))


def test_scenario_robot_lookup() -> None:
    scenario: Scenario = parse_scenario(MINIMAL)
    assert scenario.robot("r1").spec.name == "r1"
    with pytest.raises(KeyError, match="robots: \\['r1'\\]"):
        scenario.robot("r9")
