"""The configuration of one skill agent (``skimesh agent --agent-config FILE``), read from TOML.

Example (``configs/agents/pick.toml``)::

    name = "r1"                      # liveliness token agents/r1, Agent element "r1"
    conditions = ["my_pkg.conds"]    # modules whose custom condition classes are registered

    [robot]
    type = "MobileManipulator"
    label = "r1"

    [[devices]]
    type = "Gripper"
    label = "r1-gripper"

    [hardware]                       # shared devices bound to hardware parameters, by label
    sensor = "Camera-1"              # e.g. a fixed overhead camera several robots use

    [skills]
    paths = ["my_pkg.skills:Pick", "my_pkg.more_skills", "../skills/place.py"]
    entry_points = ["noop"]          # names in the entry-point group skimesh.skills; "*" = all

    [simulation]                     # simulated-outcome mode (FRIEND II)
    enabled = false
    probabilities = { pick = 0.8 }
    seed = 7

    [sensing]
    max_age = 2.0                    # default sensing_max_age for skills that set none

    [[services]]                     # an external service driven as a skill (skill_agent.external)
    service = "partner/door"
    description = { name = "open_door", doc = "open the microwave door" }

Strict: an unknown key is an error that names the file and the field (``$.robot.lable``).
Relative paths (skill files, ``event_log``, ``ontology``) are relative to the config file.
Pure: no network, nothing blocks except reading the file.

Keys (of the skill-description wire structs a ``[[services]]`` entry's ``description`` holds;
``scripts/gen_reference.py`` reads them for the agent-config reference):
    SkillDescription.name: The skill's name (what task files and plans call).
    SkillDescription.version: Version of the description, shown to people.
    SkillDescription.doc: What the skill does, for people.
    SkillDescription.parameters: The skill's parameters.
    SkillDescription.pre: Pre-conditions: must hold for the skill to start.
    SkillDescription.timeout (s): Longest run; none: no limit.
    ParamSpec.name: Parameter name.
    ParamSpec.type: An ontology class (an element parameter) or a value kind (``float``,
        ``int``, ``bool``, ``str``, ``Pose``, ``Position``, ...).
    ParamSpec.kind: ``online`` (the objects acted on), ``offline`` (configuration with
        defaults) or ``hardware`` (devices of the robot, locked while the skill runs).
    ParamSpec.doc: What the parameter means, for people.
    ParamSpec.default: Value used when none is given.
    ParamSpec.optional: The run may start without a value (it is then none).
    ParamSpec.partial: Narrows an element parameter further: label, property filters,
        relations (``?`` = the candidate).
    Query.type: Ontology class the element must have (or a subclass of it).
    Query.exact_type: Only elements of exactly ``type``, not of a subclass.
    Query.label: The element's label, if given.
    Query.filters: Property filters the element must satisfy.
    Query.related: Relations the element must take part in (``?`` = the element, ``*`` =
        anything).
    PropertyFilter.property: Data property name.
    PropertyFilter.op: Comparison with ``value`` (``near``: within ``tolerance``).
    PropertyFilter.value: The value compared with.
    PropertyFilter.tolerance: Allowed difference for ``near``.
    Relation.subject: Subject element (``?``: the element, ``*``: any).
    Relation.predicate: Ontology relation, e.g. ``contain``.
    Relation.object: Object element (``?``: the element, ``*``: any).
    RelationCond.subject: Parameter name of the subject.
    RelationCond.predicate: Ontology relation, e.g. ``contain``.
    RelationCond.object: Parameter name of the object.
    RelationCond.holds: False: the relation must not hold.
    PropertyCond.param: Parameter name of the element.
    PropertyCond.property: Data property name.
    PropertyCond.op: Comparison with ``value`` (``exists``: the property is set).
    PropertyCond.value: The value compared with.
    PropertyCond.tolerance: Allowed difference for ``near``.
    HasPropertyCond.param: Parameter name of the element.
    HasPropertyCond.property: Data property name.
    HasPropertyCond.holds: False: the element must not have the property.
    IsTypeCond.param: Parameter name of the element.
    IsTypeCond.cls: Ontology class the element must be (or a subclass of).
    EmptyCond.param: Parameter name of the location, container or gripper.
    EmptyCond.predicate: Relation that counts as holding something.
    EmptyCond.holds: False: it must hold something.
    EmptyCond.full: Instead: it holds as many things as its ``capacity`` allows.
    IsSpecifiedCond.param: Parameter that must have a value.
    CustomCond.name: Name of a condition class registered in the agent (``conditions``).
    CustomCond.params: Parameter names passed to it.
    CustomCond.args: Further arguments by name.
    AndCond.items: Conditions that must all hold.
    OrCond.items: Conditions of which one must hold.
    NotCond.item: The condition that must not hold.
"""

from __future__ import annotations

import difflib
import tomllib
from collections.abc import Iterable
from pathlib import Path
from typing import Annotated

import msgspec
from msgspec import Meta

from meshlink import check_name
from skill_agent._errors import SkillLoadError
from skill_agent.protocol._skills import SkillDescription
from wm_store.protocol import Value

__all__ = [
    "AgentConfig",
    "DeviceConfig",
    "RobotConfig",
    "SensingConfig",
    "ServiceSkillConfig",
    "SimulationConfig",
    "SkillsConfig",
    "is_file_reference",
    "load_config",
    "parse_config",
]

Probability = Annotated[float, Meta(ge=0.0, le=1.0)]


class RobotConfig(msgspec.Struct, frozen=True, kw_only=True, forbid_unknown_fields=True):
    """The robot (or appliance) the agent controls; reused in the world model by label.

    Attributes:
        type: Ontology class of the robot (or appliance).
        label: World-model label of the robot; defaults to the agent's ``name``. An element with
            this label (e.g. from the scenario) is reused.
        properties: Data properties written on the robot element (ontology property name -> value).
    """

    type: str = "Robot"
    label: str = ""
    properties: dict[str, Value] = {}


class DeviceConfig(msgspec.Struct, frozen=True, kw_only=True, forbid_unknown_fields=True):
    """One device of the robot (``hasA``): the hardware skills lock while they run.

    Attributes:
        type: Ontology class of the device, e.g. ``Arm``, ``Gripper``, ``MobileBase``, ``Camera``.
        label: World-model label of the device (unique in this file); by convention
            ``<robot>-<device>``.
        properties: Data properties written on the device element (ontology property name -> value).
    """

    type: str
    label: str
    properties: dict[str, Value] = {}


class SkillsConfig(msgspec.Struct, frozen=True, kw_only=True, forbid_unknown_fields=True):
    """Which skills the agent loads.

    Attributes:
        paths: ``pkg.mod:Class``, ``pkg.mod`` (every Skill subclass defined in it), or a file
            ``dir/skills.py`` / ``dir/skills.py:Class`` (relative to the config file).
        entry_points: Names in the entry-point group ``skimesh.skills``; ``"*"`` loads all of them.
    """

    paths: list[str] = []
    entry_points: list[str] = []


class SimulationConfig(msgspec.Struct, frozen=True, kw_only=True, forbid_unknown_fields=True):
    """Simulated-outcome mode: no hardware, outcomes drawn, effects applied to the WM.

    Attributes:
        enabled: Simulated-outcome mode: skills do not drive hardware; each run's outcome is drawn
            and its effects written to the world model.
        probabilities: By skill name or skill type; first match wins: name, type, the skill class's
            own ``success_probability``, then ``default``.
        default: Probability of skills matched by nothing else (1.0 if unset).
        seed: Makes the sequence of drawn outcomes reproducible.
        time_scale: A simulated run takes ``duration * time_scale`` seconds (0: at once).
    """

    enabled: bool = False
    probabilities: dict[str, Probability] = {}
    default: Probability | None = None
    seed: int | None = None
    time_scale: Annotated[float, Meta(ge=0)] = 0.0


class SensingConfig(msgspec.Struct, frozen=True, kw_only=True, forbid_unknown_fields=True):
    """Defaults for sensing.

    Attributes:
        max_age (s): Default ``sensing_max_age`` for skills whose description sets none: sensing is
            skipped when its data is younger.
    """

    max_age: Annotated[float, Meta(ge=0)] | None = None


class ServiceSkillConfig(msgspec.Struct, frozen=True, kw_only=True, forbid_unknown_fields=True):
    """A skill whose work is done by an external service (see :mod:`skill_agent.external`).

    Attributes:
        service: The service's name under ``skimesh/<mesh>/services/`` (segments separated by
            ``/``).
        description: The skill description the agent offers for the service (``name``, ``doc``,
            ``parameters``, ``pre``, ``post``, ...).
        goal_timeout (s): How long to wait for the service to accept a goal.
    """

    service: str
    description: SkillDescription
    goal_timeout: Annotated[float, Meta(gt=0)] = 5.0


class AgentConfig(msgspec.Struct, frozen=True, kw_only=True, forbid_unknown_fields=True):
    """Everything ``skimesh agent`` needs besides the mesh flags.

    Attributes:
        name: Agent name: its liveliness token ``agents/<name>``, its key segment and its Agent
            element in the world model.
        agent_type: Ontology class of the agent element.
        robot: The robot (or appliance) the agent controls.
        devices: The robot's devices (``hasA``): the hardware skills lock while they run.
        hardware: Hardware parameter name -> world-model label of the device bound to it: devices
            that are not parts of the robot (a fixed overhead camera, a smart platform) offered to
            this agent's skills. A bound parameter always gets that device (see
            ``skill_agent.parameters``).
        skills: Which skills the agent loads.
        services: External services driven as skills (``skill_agent.external``).
        conditions: Modules whose custom condition classes (``name`` + ``evaluate`` + ``symbolic``)
            are registered for this agent's skills.
        simulation: Simulated-outcome mode (FRIEND II): no hardware, outcomes drawn.
        sensing: Defaults for sensing.
        ontology: Extra Turtle files the skills' classes come from (as given to ``skimesh wm
            --ontology``), relative to this file.
        preempt_timeout (s): How long a stopped, timed-out or failed run's ``on_preempt`` may take.
        event_log: Append the agent's structured event log (JSON lines) to this file (relative to
            this file).
    """

    name: str
    agent_type: str = "RobotAgent"
    robot: RobotConfig = RobotConfig()
    devices: list[DeviceConfig] = []
    hardware: dict[str, str] = {}
    skills: SkillsConfig = SkillsConfig()
    services: list[ServiceSkillConfig] = []
    conditions: list[str] = []
    simulation: SimulationConfig = SimulationConfig()
    sensing: SensingConfig = SensingConfig()
    ontology: list[str] = []
    preempt_timeout: Annotated[float, Meta(gt=0)] = 5.0
    event_log: str | None = None

    def __post_init__(self) -> None:
        check_name(
            self.name, "agent name"
        )  # InvalidKeyError is a ValueError: msgspec adds the path
        labels = [d.label for d in self.devices]
        dup = sorted({label for label in labels if labels.count(label) > 1})
        if dup:
            raise ValueError(f"device labels must be unique; repeated: {', '.join(dup)}")
        empty = sorted(name for name, label in self.hardware.items() if not name or not label)
        if empty:
            raise ValueError(f"hardware bindings need a parameter name and a device label: {empty}")

    @property
    def device_labels(self) -> list[str]:
        """Labels of every device this agent drives: its machine (an appliance is its own
        device), its devices and the devices of its hardware bindings, without repeats."""
        labels = [self.robot_label, *(d.label for d in self.devices), *self.hardware.values()]
        return list(dict.fromkeys(labels))

    @property
    def robot_label(self) -> str:
        return self.robot.label or self.name

    def check_skill_names(self, names: Iterable[str]) -> None:
        """Every skill named in ``simulation.probabilities`` must be loaded.

        Raises:
            SkillLoadError: naming the unknown skill and the closest loaded one.
        """
        known = sorted(names)
        for name in self.simulation.probabilities:
            if name not in known:
                close = difflib.get_close_matches(name, known, n=1)
                hint = f"; did you mean {close[0]!r}?" if close else f" (loaded: {known})"
                raise SkillLoadError(
                    f"simulation.probabilities names skill {name!r}, which is not loaded{hint}"
                )


def is_file_reference(ref: str) -> bool:
    """True if a skill reference names a Python file (``x.py`` or ``x.py:Class``)."""
    return ref.partition(":")[0].endswith(".py")


def _resolve(base: Path, path: str) -> str:
    p = Path(path).expanduser()
    return str(p if p.is_absolute() else (base / p).resolve())


def _resolve_ref(base: Path, ref: str) -> str:
    if not is_file_reference(ref):
        return ref
    file, sep, cls = ref.partition(":")
    return _resolve(base, file) + sep + cls


def parse_config(
    text: str, *, source: str = "<config>", base_dir: Path | None = None
) -> AgentConfig:
    """Parse TOML ``text``; relative paths are made absolute against ``base_dir``.

    Raises:
        SkillLoadError: bad TOML (line and column) or a bad field (its path, e.g.
            ``$.devices[0].type``); the message starts with ``source``.
    """
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise SkillLoadError(f"{source}: not valid TOML: {e}") from None
    try:
        config = msgspec.convert(raw, AgentConfig)
    except msgspec.ValidationError as e:
        raise SkillLoadError(f"{source}: {e}") from None
    if base_dir is None:
        return config
    return msgspec.structs.replace(
        config,
        skills=msgspec.structs.replace(
            config.skills, paths=[_resolve_ref(base_dir, r) for r in config.skills.paths]
        ),
        ontology=[_resolve(base_dir, p) for p in config.ontology],
        event_log=None if config.event_log is None else _resolve(base_dir, config.event_log),
    )


def load_config(path: str | Path) -> AgentConfig:
    """Read an agent config file.

    Raises:
        SkillLoadError: the file is missing, or its content is invalid (see :func:`parse_config`).
    """
    file = Path(path)
    try:
        text = file.read_text(encoding="utf-8")
    except OSError as e:
        raise SkillLoadError(f"cannot read agent config {str(file)!r}: {e.strerror}") from None
    return parse_config(text, source=str(file), base_dir=file.resolve().parent)
