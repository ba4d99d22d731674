"""Skill plug-ins: loading from dotted paths, files and entry points, load-time ontology checks,
reload of changed code, custom condition modules, constructor injection."""

from __future__ import annotations

import sys
import textwrap
import uuid
from collections.abc import Callable, Iterator
from importlib import metadata
from pathlib import Path

import pytest

from docs.examples import test_pick_part as guide
from skill_agent import SkillLoadError
from skill_agent.external import ExternalServiceSkill
from skill_agent.protocol import SkillDescription
from skill_agent.runtime import ENTRY_POINT_GROUP, ServiceSkillConfig, SkillRegistry
from wm_store.ontology import Ontology

HEADER = """
from skill_agent.protocol import ParamSpec, RelationCond, SkillDescription, CustomCond
from skill_agent import Skill
"""

SKILLS = (
    HEADER
    + """
from docs_helper_base import Base  # a Skill subclass imported from elsewhere: not registered

class Pick(Skill):
    description = SkillDescription(
        name="pick",
        parameters=[
            ParamSpec(name="part", type="Gear"),
            ParamSpec(name="gripper", type="Gripper", kind="hardware"),
        ],
        post=[RelationCond(subject="gripper", predicate="contain", object="part")],
    )

class Place(Skill):
    description = SkillDescription(name="place", sensing_max_age=9.0)

class Helper:  # not a skill
    pass

class Abstractish(Skill):  # no description: a base class, not a skill
    pass
"""
)

BASE = HEADER + 'class Base(Skill):\n    description = SkillDescription(name="base")\n'


@pytest.fixture
def ontology() -> Ontology:
    return Ontology.default()


@pytest.fixture
def make_module(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[Callable[[str], str]]:
    """Write ``source`` as a fresh importable module; returns its dotted name."""
    monkeypatch.syspath_prepend(str(tmp_path))
    (tmp_path / "docs_helper_base.py").write_text(BASE)
    created: list[str] = []

    def make(source: str) -> str:
        name = f"skills_{uuid.uuid4().hex[:8]}"
        (tmp_path / f"{name}.py").write_text(textwrap.dedent(source))
        created.append(name)
        return name

    yield make
    for name in [*created, "docs_helper_base"]:
        sys.modules.pop(name, None)


def test_dotted_module_loads_every_skill_defined_in_it(
    ontology: Ontology, make_module: Callable[[str], str]
) -> None:
    mod = make_module(SKILLS)
    entries = SkillRegistry(ontology, paths=[mod]).load()
    assert sorted(entries) == ["pick", "place"], "imported, abstract and non-skill classes skipped"
    assert entries["pick"].source == f"{mod} (config)"
    assert entries["pick"].factory().__class__.__name__ == "Pick"


def test_dotted_class_and_errors(ontology: Ontology, make_module: Callable[[str], str]) -> None:
    mod = make_module(SKILLS)
    assert list(SkillRegistry(ontology, paths=[f"{mod}:Place"]).load()) == ["place"]
    with pytest.raises(SkillLoadError, match=r"has no 'Pik'.*did you mean 'Pick'"):
        SkillRegistry(ontology, paths=[f"{mod}:Pik"]).load()
    with pytest.raises(SkillLoadError, match="is not a Skill subclass"):
        SkillRegistry(ontology, paths=[f"{mod}:Helper"]).load()
    with pytest.raises(SkillLoadError, match="has no SkillDescription"):
        SkillRegistry(ontology, paths=[f"{mod}:Abstractish"]).load()
    with pytest.raises(SkillLoadError, match=r"cannot import 'no_such_mod_x' \(config\)"):
        SkillRegistry(ontology, paths=["no_such_mod_x"]).load()
    with pytest.raises(
        SkillLoadError, match=r"standard skills are named skill_agent.skills:<Class>"
    ):
        SkillRegistry(ontology, paths=["skill_agent.skills.pick:Pick"]).load()
    assert list(SkillRegistry(ontology, paths=["skill_agent.skills:Pick"]).load()) == ["pick"]
    empty = make_module("X = 1\n")
    with pytest.raises(SkillLoadError, match="defines no Skill subclass"):
        SkillRegistry(ontology, paths=[empty]).load()


def test_file_reference(ontology: Ontology, tmp_path: Path) -> None:
    path = tmp_path / "file_skills.py"
    path.write_text(
        HEADER + 'class Wave(Skill):\n    description = SkillDescription(name="wave")\n'
    )
    assert list(SkillRegistry(ontology, paths=[str(path)]).load()) == ["wave"]
    assert list(SkillRegistry(ontology, paths=[f"{path}:Wave"]).load()) == ["wave"]
    with pytest.raises(SkillLoadError, match="does not exist"):
        SkillRegistry(ontology, paths=[str(tmp_path / "missing.py")]).load()
    broken = tmp_path / "broken.py"
    broken.write_text("def oops(:\n")
    with pytest.raises(SkillLoadError, match=r"SyntaxError.*broken\.py"):
        SkillRegistry(ontology, paths=[str(broken)]).load()


def test_misspelt_class_fails_at_load_naming_skill_module_and_closest(
    ontology: Ontology, make_module: Callable[[str], str]
) -> None:
    mod = make_module(SKILLS.replace('type="Gear"', 'type="Gaer"'))
    with pytest.raises(SkillLoadError) as info:
        SkillRegistry(ontology, paths=[mod]).load()
    message = str(info.value)
    assert mod in message, "names the module the skill came from"
    assert "skill 'pick'" in message
    assert "unknown type 'Gaer'" in message and "did you mean 'Gear'" in message


def test_misspelt_relation_fails_at_load(
    ontology: Ontology, make_module: Callable[[str], str]
) -> None:
    mod = make_module(SKILLS.replace('predicate="contain"', 'predicate="contian"'))
    with pytest.raises(SkillLoadError, match=r"(?s)skill 'pick'.*contian.*'contain'"):
        SkillRegistry(ontology, paths=[mod]).load()


def test_duplicate_names_are_refused(ontology: Ontology, make_module: Callable[[str], str]) -> None:
    a, b = make_module(SKILLS), make_module(SKILLS)
    with pytest.raises(SkillLoadError, match=f"two skills are called 'pick': {a}.*{b}"):
        SkillRegistry(ontology, paths=[a, b]).load()


def test_entry_points(
    ontology: Ontology, make_module: Callable[[str], str], monkeypatch: pytest.MonkeyPatch
) -> None:
    mod = make_module(SKILLS)
    installed = metadata.EntryPoints(
        [
            metadata.EntryPoint("pick", f"{mod}:Pick", ENTRY_POINT_GROUP),
            metadata.EntryPoint("place", f"{mod}:Place", ENTRY_POINT_GROUP),
        ]
    )

    def entry_points(*, group: str) -> metadata.EntryPoints:
        return installed.select(group=group)

    monkeypatch.setattr("skill_agent.runtime._plugins.metadata.entry_points", entry_points)
    entries = SkillRegistry(ontology, entry_points=["pick"]).load()
    assert list(entries) == ["pick"]
    assert entries["pick"].source == f"{mod}:Pick (entry point 'pick')"
    assert sorted(SkillRegistry(ontology, entry_points=["*"]).load()) == ["pick", "place"]
    with pytest.raises(SkillLoadError, match=r"no entry point 'pik'.*'pick'"):
        SkillRegistry(ontology, entry_points=["pik"]).load()


def test_sensing_default_and_services(
    ontology: Ontology, make_module: Callable[[str], str]
) -> None:
    mod = make_module(SKILLS)
    service = ServiceSkillConfig(service="partner/door", description=SkillDescription(name="door"))
    entries = SkillRegistry(ontology, paths=[mod], services=[service], sensing_max_age=2.0).load()
    assert entries["pick"].description.sensing_max_age == 2.0, "the default fills in"
    assert entries["place"].description.sensing_max_age == 9.0, "a skill's own value wins"
    door = entries["door"].factory()
    assert isinstance(door, ExternalServiceSkill) and door.service == "partner/door"


def test_constructor_injection(ontology: Ontology, make_module: Callable[[str], str]) -> None:
    mod = make_module(
        HEADER
        + """
class Needy(Skill):
    description = SkillDescription(name="needy")
    def __init__(self, *, mesh=None, other=None):
        self.mesh, self.other = mesh, other
"""
    )
    entries = SkillRegistry(ontology, paths=[mod], context={"mesh": "M", "unused": 1}).load()
    skill = entries["needy"].factory()
    assert skill.mesh == "M" and skill.other is None  # type: ignore[attr-defined]


CONDITIONS = """
from skill_agent.conditions import Verdict

class Heavy:
    name = "heavy"
    def evaluate(self, view, bindings, params, args):
        return Verdict(True, "heavy enough")
    def symbolic(self, params, args):
        return None
"""


def test_condition_modules_register_custom_conditions(
    ontology: Ontology, make_module: Callable[[str], str]
) -> None:
    skills = make_module(
        HEADER
        + """
class Lift(Skill):
    description = SkillDescription(
        name="lift",
        parameters=[ParamSpec(name="part", type="Gear")],
        pre=[CustomCond(name="heavy", params=["part"])],
    )
"""
    )
    with pytest.raises(SkillLoadError, match="heavy"):
        SkillRegistry(ontology, paths=[skills]).load()
    conds = make_module(CONDITIONS)
    registry = SkillRegistry(ontology, paths=[skills], condition_modules=[conds])
    assert list(registry.load()) == ["lift"]
    assert "heavy" in registry.conditions
    assert list(registry.reload()) == ["lift"], "re-registering on reload is allowed"


def version_source(version: int, name: str = "probe") -> str:
    return HEADER + textwrap.dedent(
        f"""
        VERSION = {version}

        class Probe(Skill):
            description = SkillDescription(name="{name}", version="{version}.0")
            def version(self):
                return VERSION * 10 + {version}
        """
    )


def test_reload_picks_up_changed_code(
    ontology: Ontology, make_module: Callable[[str], str], tmp_path: Path
) -> None:
    mod = make_module(version_source(1))
    registry = SkillRegistry(ontology, paths=[mod])
    old = registry.load()["probe"]
    # Same length, same second: stale bytecode would be reused without the registry's care.
    (tmp_path / f"{mod}.py").write_text(version_source(2))
    new = registry.reload()["probe"]
    assert new.description.version == "2.0" and registry.entries["probe"] is new
    assert new.factory().version() == 22  # type: ignore[attr-defined]
    assert old.description.version == "1.0", "entries handed out before keep their description"
    assert old.factory().version() == 21, "old classes keep their code (globals are shared)"  # type: ignore[attr-defined]


def test_failed_reload_keeps_current_entries(
    ontology: Ontology, make_module: Callable[[str], str], tmp_path: Path
) -> None:
    mod = make_module(version_source(1))
    registry = SkillRegistry(ontology, paths=[mod])
    first = registry.load()
    (tmp_path / f"{mod}.py").write_text(version_source(2).replace("SkillDescription(", "Broken("))
    with pytest.raises(SkillLoadError, match="NameError"):
        registry.reload()
    assert registry.entries == first


def test_file_modules_reload_too(ontology: Ontology, tmp_path: Path) -> None:
    path = tmp_path / "probe_file.py"
    path.write_text(version_source(1))
    registry = SkillRegistry(ontology, paths=[str(path)])
    assert registry.load()["probe"].description.version == "1.0"
    path.write_text(version_source(3))
    assert registry.reload()["probe"].description.version == "3.0"


@pytest.fixture(autouse=True)
def _no_leaked_modules() -> Iterator[None]:
    before = set(sys.modules)
    yield
    for name in set(sys.modules) - before:
        if name.startswith(("skills_", "skimesh_skills_")):
            sys.modules.pop(name, None)


# The guide's example tests (docs/examples/test_pick_part.py) run with the unit tests.
test_guide_pick_part = guide.test_pick_part_runs_and_commits_its_prediction
test_guide_pick_part_simulated = guide.test_pick_part_in_simulated_outcome_mode
test_guide_pick_part_stop = guide.test_a_stop_opens_the_gripper_and_the_event_log_records_it
