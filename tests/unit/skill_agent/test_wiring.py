"""Wiring an agent to its devices and sensors: drivers bound to world-model elements by label
(an agent named like its robot), the configuration's ``[hardware]`` bindings (a shared overhead
camera), optional hardware filled from the agent's one device, container capacities from the
ontology's templates, and ``skimesh agent --scenario S --robot R`` through the scenario file."""

from __future__ import annotations

from collections.abc import AsyncIterator
from dataclasses import dataclass
from pathlib import Path

import anyio
import pytest

from scenario import load_scenario
from scenario.wm import scenario_ops, template_capacity
from skill_agent import ParameterError, SkillLoadError
from skill_agent.conditions import evaluate
from skill_agent.parameters import specify
from skill_agent.runtime import (
    bind_devices,
    bind_hardware,
    element_for_label,
    load_config,
    parse_config,
)
from skill_agent.server import agent_registration
from skill_agent.skills import Locate, Pick
from skill_agent.skills._params import not_full
from skimesh.commands.agent import scenario_config_path
from wm_store import DuplicateLabelError, InMemoryTransport, NameConflictError, WmClient
from wm_store.ontology import Ontology, Prop
from wm_store.protocol import AddElement, Relation
from wm_store.server import WmService, WmStore

pytestmark = pytest.mark.anyio

ROOT = Path(__file__).resolve().parents[3]
SCENARIOS = ROOT / "configs" / "scenarios"
AGENTS = ROOT / "configs" / "agents"


@dataclass(frozen=True)
class FakeDriver:
    name: str


class Scene:
    def __init__(self, wm: WmClient, ids: dict[str, str]) -> None:
        self.wm, self.ids = wm, ids

    def __getitem__(self, label: str) -> str:
        return self.ids[label]

    async def register(self, config_path: Path) -> str:
        """Register the agent as ``run_agent`` does; returns its robot's element id."""
        config = load_config(config_path)
        await self.wm.register_robot(agent_registration(config, []))
        [agent] = self.wm.resolve_element(type="Agent", label=config.name)
        return self.wm.query_relation(agent.id, "controls")[0].object


@pytest.fixture
async def wm() -> AsyncIterator[WmClient]:
    ontology = Ontology.default()
    store = await WmStore.open(ontology)
    async with anyio.create_task_group() as tg:
        await tg.start(store.run)
        async with WmClient.connect(InMemoryTransport(WmService(store)), ontology) as client:
            yield client
        tg.cancel_scope.cancel()


async def scene(wm: WmClient, name: str) -> Scene:
    reply = await wm.transact(scenario_ops(load_scenario(SCENARIOS / name / "scenario.toml")))
    return Scene(wm, {ref[1:]: eid for ref, eid in reply.ids.items() if ref.startswith("$")})


# --------------------------------------------------------------------------- by label


async def test_drivers_are_bound_to_the_registered_devices_by_label(wm: WmClient) -> None:
    s = await scene(wm, "kitting")
    robot = await s.register(AGENTS / "kitting" / "r1.toml")
    assert robot == s["r1"], "the robot of the scene is reused, not added again"
    config = load_config(AGENTS / "kitting" / "r1.toml")
    drivers = {label: FakeDriver(label) for label in ("r1-arm", "r1-camera", "Camera-1", "r2-arm")}
    devices = bind_devices(wm, config.device_labels, drivers, robot=robot)
    assert devices == {
        s["r1-arm"]: drivers["r1-arm"],
        s["r1-camera"]: drivers["r1-camera"],
        s["Camera-1"]: drivers["Camera-1"],
    }
    assert s["Camera-1"] == "Camera-1", "a label of the form <its class>-<n> is its id"
    assert s["r1-camera"] != "Camera-1", "the robot's camera, added first, skipped that id"
    assert bind_hardware(wm, config.hardware, robot=robot) == {"sensor": s["Camera-1"]}


async def test_a_label_shared_by_an_agent_and_its_robot_means_the_robot(wm: WmClient) -> None:
    s = await scene(wm, "kitting")
    robot = await s.register(AGENTS / "kitting" / "r1.toml")
    assert {e.type for e in wm.resolve_element(label="r1")} == {"RobotAgent", "MobileManipulator"}
    assert element_for_label(wm, "r1") == robot


async def test_a_device_label_names_one_element(wm: WmClient) -> None:
    s = await scene(wm, "kitting")
    with pytest.raises(DuplicateLabelError, match=rf"'r1-camera'.*{s['r1-camera']}"):
        await wm.transact([AddElement(type="Camera", label="r1-camera")])  # a stray namesake
    with pytest.raises(NameConflictError, match=rf"'{s['r1-camera']}'.*r1-camera"):
        await wm.transact([AddElement(type="Camera", label=s["r1-camera"])])
    assert element_for_label(wm, "r1-camera") == s["r1-camera"]


async def test_an_unknown_label_is_a_load_error_naming_it(wm: WmClient) -> None:
    await scene(wm, "kitting")
    with pytest.raises(SkillLoadError, match=r"'Camera-9': no element"):
        bind_hardware(wm, {"sensor": "Camera-9"})
    assert bind_devices(wm, ["Camera-9"], {}) == {}, "a label without a driver is skipped"


# --------------------------------------------------------------------------- [hardware]


def test_the_config_binds_shared_devices_to_hardware_parameters() -> None:
    config = parse_config(
        'name = "r1"\n[robot]\nlabel = "r1"\n[[devices]]\ntype = "Arm"\nlabel = "r1-arm"\n'
        '[hardware]\nsensor = "Camera-1"\nplatform = "r1-arm"\n'
    )
    assert config.hardware == {"sensor": "Camera-1", "platform": "r1-arm"}
    assert config.device_labels == ["r1", "r1-arm", "Camera-1"]
    assert parse_config('name = "r1"').hardware == {}, "optional: older configs still load"
    with pytest.raises(SkillLoadError, match="parameter name and a device label"):
        parse_config('name = "r1"\n[hardware]\nsensor = ""\n')
    with pytest.raises(SkillLoadError, match=r"\$\.hardware"):
        parse_config('name = "r1"\n[hardware]\nsensor = 3\n')


async def test_a_bound_parameter_gets_the_configured_device(wm: WmClient) -> None:
    s = await scene(wm, "kitting")
    robot = await s.register(AGENTS / "kitting" / "r1.toml")
    hardware = {"sensor": s["Camera-1"]}
    given = {"object": s["Gear-1"]}
    free = specify(Locate.description, given, wm, hardware=hardware, robot=robot)
    assert free.values["sensor"] == s["Camera-1"]
    # a planner binds the robot's own camera (its only hasA sensor): the binding wins, visibly
    asked = specify(
        Locate.description, {**given, "sensor": s["r1-camera"]}, wm, hardware=hardware, robot=robot
    )
    assert asked.values["sensor"] == s["Camera-1"]
    assert asked.inferred["sensor"] == (
        "Camera-1: this agent's 'sensor' device, bound by its configuration "
        f"(r1-camera ({s['r1-camera']}) was asked for)"
    )
    unbound = specify(Locate.description, {**given, "sensor": s["r1-camera"]}, wm, robot=robot)
    assert unbound.values["sensor"] == s["r1-camera"], "without a binding the request wins"
    with pytest.raises(ParameterError, match="is not a device of this agent"):
        specify(
            Locate.description,
            {**given, "sensor": s["r2-camera"]},
            wm,
            hardware=hardware,
            robot=robot,
        )


# --------------------------------------------------------------------------- optional hardware


async def test_optional_hardware_takes_the_agents_one_device(wm: WmClient) -> None:
    s = await scene(wm, "meal")
    robot = await s.register(AGENTS / "meal" / "friend.toml")
    given = {"object": s["MealBox-1"]}
    # no binding: no SmartPlatform among friend's devices -> None
    assert specify(Locate.description, given, wm, robot=robot).values["platform"] is None
    # bound by the configuration
    bound = {"sensor": s["Camera-1"], "platform": s["Worktop-1"]}
    spec = specify(Locate.description, given, wm, hardware=bound, robot=robot)
    assert spec.values["platform"] == s["Worktop-1"]
    assert (
        spec.inferred["platform"] == f"Worktop-1 ({s['Worktop-1']}): this agent's 'platform' device"
    )
    # the agent's one device of the class, offered but not bound to the name
    offered = {"sensor": s["Camera-1"], "extra": s["Worktop-1"]}
    spec = specify(Locate.description, given, wm, hardware=offered, robot=robot)
    assert spec.values["platform"] == s["Worktop-1"]
    assert spec.inferred["platform"].endswith("this agent's only SmartPlatform (optional)")
    # asked for None on purpose: stays None
    spec = specify(
        Locate.description, {**given, "platform": None}, wm, hardware=offered, robot=robot
    )
    assert spec.values["platform"] is None and "platform" not in spec.inferred


async def test_optional_hardware_stays_empty_when_the_choice_is_ambiguous(wm: WmClient) -> None:
    s = await scene(wm, "meal")
    robot = await s.register(AGENTS / "meal" / "friend.toml")
    reply = await wm.transact(
        [AddElement(type="SmartPlatform", label="pad", relations=[Relation(robot, "hasA", "$")])]
    )
    offered = {"sensor": s["Camera-1"], "extra": s["Worktop-1"]}
    spec = specify(Pick.description, {"object": s["MealBox-1"]}, wm, hardware=offered, robot=robot)
    assert reply.ids["#0"] != s["Worktop-1"]
    assert spec.values["platform"] is None, "two smart platforms: an optional one is not guessed"


# --------------------------------------------------------------------------- capacity


async def test_containers_get_the_capacity_of_their_template(wm: WmClient) -> None:
    kitting = await scene(wm, "kitting")
    assert wm.get_element(kitting["KitBox-1"]).properties[Prop.capacity] == 6
    assert wm.get_element(kitting["PartBox-1"]).properties[Prop.capacity] == 20
    assert Prop.capacity not in wm.get_element(kitting["Gear-1"]).properties
    assert template_capacity(Ontology.default(), "Tray") == 2
    assert template_capacity(Ontology.default(), "NoSuchClass") is None


async def test_a_full_kit_box_refuses_another_part(wm: WmClient) -> None:
    s = await scene(wm, "kitting")
    kit = s["KitBox-1"]
    room = evaluate(not_full("container"), wm, {"container": kit})
    assert room.ok and "holds 0 of 6 (its 'capacity')" in room.reason
    await wm.transact(
        [AddElement(type="Gear", relations=[Relation(kit, "contain", "$")]) for _ in range(6)]
    )
    full = evaluate(not_full("container"), wm, {"container": kit})
    assert not full.ok and "holds 6 of 6" in full.reason


# --------------------------------------------------------------------------- skimesh agent


def test_the_scenario_names_each_agents_config() -> None:
    assert scenario_config_path("kitting", "r1") == AGENTS / "kitting" / "r1.toml"
    microwave = AGENTS / "meal" / "microwave.toml"
    assert scenario_config_path("meal", "Microwave-1") == microwave  # the appliance's label
    assert scenario_config_path("meal", "microwave") == microwave  # or its agent's name
    with pytest.raises(FileNotFoundError, match=r"no agent for 'r3'; it has: r1, r2"):
        scenario_config_path("kitting", "r3")
