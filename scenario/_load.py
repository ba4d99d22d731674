"""Reading and checking scenario files (pure: no MuJoCo; nothing blocks but the file read).

:func:`load_scenario` parses TOML into a :class:`~scenario.Scenario` (field
types and ranges, unknown keys refused) and then checks what types cannot: labels unique,
labels of the form of an id only on elements of that class (:func:`_id_shaped_label_problems`),
parents and mounts that exist and may hold the child, no container cycles, sensors complete,
a fixed robot neither a MobileManipulator nor carrying anything, goals well formed and naming
known labels. Agent config paths become absolute.

:func:`read_scenario` finds a scenario by name in a directory of scenarios
(``<scenarios>/NAME/scenario.toml``) or takes a file; :func:`known_scenarios` lists the names.
"""

from __future__ import annotations

import difflib
import tomllib
from collections.abc import Callable, Iterable
from pathlib import Path

import msgspec

from scenario._errors import ScenarioError
from scenario._schema import CABINET_TOP, DRAWER_CLEARANCE, GOAL, RobotEntry, Scenario

__all__ = [
    "check_scenario",
    "known_scenarios",
    "load_scenario",
    "parse_scenario",
    "read_scenario",
]


def load_scenario(path: str | Path) -> Scenario:
    """Read and check a scenario file.

    Raises:
        ScenarioError: the file cannot be read, is not TOML, or is invalid; the message starts
            with the file name and names the field path.
    """
    file = Path(path)
    try:
        text = file.read_text(encoding="utf-8")
    except OSError as e:
        raise ScenarioError(f"cannot read the scenario: {e.strerror}", source=str(file)) from None
    return parse_scenario(text, source=str(file), base_dir=file.resolve().parent)


def known_scenarios(scenarios: Path) -> list[str]:
    """The names of the scenarios in the directory ``scenarios`` (``NAME/scenario.toml``)."""
    return sorted(p.parent.name for p in scenarios.glob("*/scenario.toml"))


def read_scenario(name_or_path: str, scenarios: Path) -> Scenario:
    """A scenario file given by path, else the scenario ``name_or_path`` in the directory
    ``scenarios``.

    Raises:
        ScenarioError: no such file or scenario (the message lists the known names), or the
            scenario is invalid (see :func:`load_scenario`).
    """
    path = Path(name_or_path)
    if not path.is_file():
        path = scenarios / name_or_path / "scenario.toml"
        if not path.exists():
            known = ", ".join(known_scenarios(scenarios)) or "none"
            raise ScenarioError(
                f"no scenario {name_or_path!r}: give a scenario name ({known}) or a scenario file"
            )
    return load_scenario(path)


def parse_scenario(
    text: str, *, source: str = "<scenario>", base_dir: Path | None = None
) -> Scenario:
    """Parse and check TOML ``text``; agent and MJCF file paths are resolved against
    ``base_dir``.

    Raises:
        ScenarioError: as :func:`load_scenario`.
    """
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise ScenarioError(f"not valid TOML: {e}", source=source) from None
    try:
        scenario = msgspec.convert(raw, Scenario)
    except msgspec.ValidationError as e:
        raise ScenarioError(str(e), source=source) from None
    if base_dir is not None:
        scenario = _resolve_paths(scenario, base_dir)
    scenario = msgspec.structs.replace(scenario, source=source)
    check_scenario(scenario)
    return scenario


def _resolve_paths(scenario: Scenario, base: Path) -> Scenario:
    def resolve(path: str) -> str:
        if not path:
            return path
        p = Path(path).expanduser()
        return str(p if p.is_absolute() else (base / p).resolve())

    def robot(r: RobotEntry) -> RobotEntry:
        model, files = r.model, r.model.mjcf
        if files is not None:
            files = msgspec.structs.replace(
                files, arm_xml=resolve(files.arm_xml), gripper_xml=resolve(files.gripper_xml)
            )
            model = msgspec.structs.replace(model, mjcf=files)
        return msgspec.structs.replace(r, agent=resolve(r.agent), model=model)

    return msgspec.structs.replace(
        scenario,
        robots=[robot(r) for r in scenario.robots],
        appliances=[
            msgspec.structs.replace(a, agent=resolve(a.agent)) for a in scenario.appliances
        ],
        ontology=[resolve(p) for p in scenario.ontology],
    )


def _unknown(field: str, value: str, kinds: str, known: Iterable[str]) -> str:
    names = sorted(known)
    close = difflib.get_close_matches(value, names, n=1)
    hint = f"did you mean {close[0]!r}?" if close else f"{kinds}: {names or 'none'}"
    return f"{field}: unknown {kinds[:-1] if kinds.endswith('s') else kinds} {value!r}; {hint}"


def check_scenario(s: Scenario) -> None:
    """Check what field types cannot (see module doc).

    Raises:
        ScenarioError: the first problem, with its field path.
    """
    src = s.source or "<scenario>"

    def fail(message: str) -> None:
        raise ScenarioError(message, source=src)

    seen: dict[str, str] = {}
    for where, label in _all_labels(s):
        if label in seen:
            fail(f"{where}: label {label!r} is already used by {seen[label]}")
        seen[label] = where
    for problem in _id_shaped_label_problems(s):
        fail(problem)
    robots = {r.name for r in s.robots}
    furniture = {f.label: f for f in s.furniture}
    containers = {c.label: c for c in s.containers}
    appliances = {a.label for a in s.appliances}

    for i, f in enumerate(s.furniture):
        if f.drawer is not None and f.kind != "cabinet":
            fail(f"$.furniture[{i}].drawer: only a cabinet has a drawer (shape {f.kind!r})")
        if f.kind == "cabinet" and f.drawer is not None:
            room = f.size[2] - CABINET_TOP - 2 * DRAWER_CLEARANCE - 0.05
            if f.drawer.height > room:
                fail(
                    f"$.furniture[{i}].drawer.height: {f.drawer.height} m does not fit under "
                    f"the top (at most {room:.3f} m)"
                )
            if f.drawer.travel > 0.8 * f.size[0]:
                fail(
                    f"$.furniture[{i}].drawer.travel: {f.drawer.travel} m pulls the drawer "
                    f"out of a {f.size[0]} m deep cabinet (at most {0.8 * f.size[0]:.3f} m)"
                )
        if f.station and (f.station not in furniture or furniture[f.station].kind != "area"):
            areas = (k for k, v in furniture.items() if v.kind == "area")
            fail(_unknown(f"$.furniture[{i}].station", f.station, "stations", areas))
    holders = robots | set(furniture) | set(containers)
    for i, c in enumerate(s.containers):
        if c.parent and c.parent not in holders:
            fail(_unknown(f"$.containers[{i}].parent", c.parent, "holders", holders))
        chain, parent = [c.label], c.parent
        while parent in containers:
            if parent in chain:
                fail(f"$.containers[{i}].parent: containers form a cycle {' -> '.join(chain)}")
            chain.append(parent)
            parent = containers[parent].parent
    _check_fixed_robots(s, fail)
    for i, p in enumerate(s.parts):
        if p.parent not in set(furniture) | set(containers) | appliances:
            fail(
                _unknown(
                    f"$.parts[{i}].parent", p.parent, "holders", set(containers) | set(furniture)
                )
            )
    for i, a in enumerate(s.appliances):
        if a.parent and a.parent not in furniture:
            fail(_unknown(f"$.appliances[{i}].parent", a.parent, "furniture", furniture))
    for i, sensor in enumerate(s.sensors):
        where = f"$.sensors[{i}]"
        if sensor.kind == "platform":
            if sensor.surface not in furniture:
                fail(_unknown(f"{where}.surface", sensor.surface, "furniture", furniture))
        elif sensor.mount:
            if sensor.mount not in robots:
                fail(_unknown(f"{where}.mount", sensor.mount, "robots", robots))
        elif sensor.position is None or sensor.look_at is None:
            fail(f"{where}: a fixed camera needs position and look_at (or mount = a robot)")
    keys = [(x.owner, x.device_name) for x in s.sensors]
    keys += [(r.name, d) for r in s.robots for d in r.spec.devices]
    for owner, device in keys:
        if keys.count((owner, device)) > 1:
            fail(f"$.sensors: two devices are {owner}/{device}; set `device` to tell them apart")
    for i, goal in enumerate(s.goals):
        m = GOAL.fullmatch(goal)
        if m is None:
            fail(f"$.goals[{i}]: {goal!r} is not of the form predicate(Label, ...)")
            continue
        for arg in (a.strip() for a in m.group(1).split(",") if a.strip()):
            if arg not in seen:
                fail(_unknown(f"$.goals[{i}]", arg, "labels", seen))


def _check_fixed_robots(s: Scenario, fail: Callable[[str], None]) -> None:
    """A fixed robot (``model.mount = "fixed"``) has no base: it is no MobileManipulator,
    carries no container (no deck) and has no front camera."""
    fixed = {r.name for r in s.robots if r.spec.fixed}
    for i, r in enumerate(s.robots):
        if r.name in fixed and r.type == "MobileManipulator":
            fail(
                f'$.robots[{i}].type: a fixed robot (model.mount = "fixed") has no MobileBase, '
                'so it is no MobileManipulator; e.g. type = "Robot"'
            )
    for i, c in enumerate(s.containers):
        if c.parent in fixed:
            fail(
                f"$.containers[{i}].parent: {c.parent!r} is fixed and has no deck; put the "
                "container on furniture within its reach"
            )
    for i, sensor in enumerate(s.sensors):
        if sensor.kind == "camera" and sensor.mount in fixed and sensor.site == "front_camera":
            fail(f'$.sensors[{i}].site: fixed robot {sensor.mount!r} has only "wrist_camera"')


_SCENE_CLASSES = ("Location", "Arm", "Gripper", "MobileBase")
"""Classes of the elements the scene adds beside the scenario's own: robots' homes, devices."""


def _id_shaped_label_problems(s: Scenario) -> list[str]:
    """Labels of the form of an element id, ``<Class>-<n>`` with ``Class`` a class of the
    scene's elements, on an element of another class (a Gear labelled ``Shaft-2`` in a scene
    with shafts): each the message of a refusal, with its field path.

    The rule: a label shaped like an id is the id of its own element (the store gives a
    ``Gear`` labelled ``Gear-3`` the id ``Gear-3``) and never another element's; other labels
    (``Pulley-4`` where there is no Pulley, ``r1-home``) are names, never taken for ids."""
    typed = _typed_labels(s)
    classes = {cls for _, _, cls in typed} | set(_SCENE_CLASSES)
    problems = []
    for where, label, cls in typed:
        head, sep, tail = label.rpartition("-")
        if sep and tail.isdigit() and head in classes and head != cls:
            problems.append(
                f"{where}: label {label!r} has the form of an id of a {head}, but it labels a "
                f"{cls}; a label <Class>-<n> must be of the element's own class (it becomes "
                f"its id, and names no other element): call it {cls}-<n>, or a name that is "
                "not of that form"
            )
    return problems


def _typed_labels(s: Scenario) -> list[tuple[str, str, str]]:
    """(field path, label, class) of the scenario's elements (robots' devices aside)."""
    found = [(f"$.robots[{i}].name", r.name, r.type) for i, r in enumerate(s.robots)]
    found += [(f"$.furniture[{i}].label", f.label, f.type) for i, f in enumerate(s.furniture)]
    found += [
        (f"$.furniture[{i}].drawer.label", f.drawer.label, f.drawer.type)
        for i, f in enumerate(s.furniture)
        if f.drawer is not None
    ]
    found += [(f"$.containers[{i}].label", c.label, c.type) for i, c in enumerate(s.containers)]
    found += [(f"$.parts[{i}].label", p.label, p.type) for i, p in enumerate(s.parts)]
    found += [(f"$.appliances[{i}].label", a.label, a.type) for i, a in enumerate(s.appliances)]
    found += [
        (f"$.sensors[{i}].label", x.label, x.ontology_type)
        for i, x in enumerate(s.sensors)
        if not (x.kind == "platform" and x.label == x.surface)
    ]
    return found


def _all_labels(s: Scenario) -> list[tuple[str, str]]:
    found: list[tuple[str, str]] = []
    for i, r in enumerate(s.robots):
        found.append((f"$.robots[{i}].name", r.name))
        found += [(f"$.robots[{i}] (device)", f"{r.name}-{d}") for d in r.spec.devices]
    found += [(f"$.furniture[{i}].label", f.label) for i, f in enumerate(s.furniture)]
    found += [
        (f"$.furniture[{i}].drawer.label", f.drawer.label)
        for i, f in enumerate(s.furniture)
        if f.drawer is not None
    ]
    found += [(f"$.containers[{i}].label", c.label) for i, c in enumerate(s.containers)]
    found += [(f"$.parts[{i}].label", p.label) for i, p in enumerate(s.parts)]
    found += [(f"$.appliances[{i}].label", a.label) for i, a in enumerate(s.appliances)]
    for i, sensor in enumerate(s.sensors):  # a smart platform may share its surface's label
        if not (sensor.kind == "platform" and sensor.label == sensor.surface):
            found.append((f"$.sensors[{i}].label", sensor.label))
    return found
