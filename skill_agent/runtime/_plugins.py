"""Skill plug-ins: :class:`SkillRegistry` imports skill classes, checks them against the
ontology, and re-imports them on request (reload without restarting the agent).

Where skills come from (an agent config's ``[skills]`` and ``[[services]]``):

- dotted paths: ``pkg.mod:Class`` (one class) or ``pkg.mod`` (every :class:`Skill` subclass
  *defined* in the module that has a ``description``);
- Python files: ``dir/skills.py`` or ``dir/skills.py:Class`` (no package needed);
- entry points of the group ``skimesh.skills`` (name = what configs list, value = a dotted path
  as above), so an installed distribution can ship skills::

      [project.entry-points."skimesh.skills"]
      pick = "my_robot.skills:Pick"

- external services (:func:`skill_agent.external.external_skill`).

Every description is checked at load with :func:`skill_agent.parameters.check_description`: a
misspelt class, relation or property fails here, with the closest known name, and the message
names the skill and where it came from. Modules listed as condition modules are imported
first; every custom condition class defined in them is registered for the agent.

:meth:`SkillRegistry.reload` re-imports every module (``importlib.reload``; files are executed
afresh) and builds new :class:`~skill_agent.runtime.SkillEntry` objects; the agent hands them to
``AgentCore.replace_skills``. Runs in flight keep the classes they started with; module-level
globals are shared (a reload re-executes the module in place). A reload that fails leaves the
current entries untouched.

Importing runs plug-in code: call :meth:`load` / :meth:`reload` in a worker thread from async
code (``anyio.to_thread.run_sync``).
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import importlib
import importlib.util
import inspect
import sys
import threading
from collections.abc import Callable, Iterable, Mapping, Sequence
from importlib import metadata
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING

import msgspec

from skill_agent._errors import SkillError, SkillLoadError
from skill_agent._skill import Skill
from skill_agent.conditions._model import ConditionRegistry
from skill_agent.external import external_skill
from skill_agent.parameters._check import check_description
from skill_agent.protocol._skills import SkillDescription
from skill_agent.runtime._agent import SkillEntry
from skill_agent.runtime._config import AgentConfig, ServiceSkillConfig, is_file_reference
from wm_store import WmError
from wm_store.ontology import did_you_mean

if TYPE_CHECKING:
    from wm_store.ontology import Ontology

__all__ = ["ENTRY_POINT_GROUP", "SkillRegistry", "entry_point_skills"]

_STANDARD = "skill_agent.skills"
"""The standard library's one public path (its modules are private)."""

ENTRY_POINT_GROUP = "skimesh.skills"


def entry_point_skills(names: Iterable[str]) -> list[tuple[str, str]]:
    """``(value, origin)`` of the ``skimesh.skills`` entry points called ``names`` (``"*"``:
    all of them, sorted by name).

    Raises:
        SkillLoadError: a name is not installed (names the closest and lists the installed).
    """
    installed = {ep.name: ep for ep in metadata.entry_points(group=ENTRY_POINT_GROUP)}
    wanted = list(names)
    if "*" in wanted:
        wanted = sorted(installed)
    found: list[tuple[str, str]] = []
    for name in wanted:
        ep = installed.get(name)
        if ep is None:
            raise SkillLoadError(
                f"no entry point {name!r} in group {ENTRY_POINT_GROUP!r}"
                f"{did_you_mean(name, installed)} Installed: {sorted(installed) or 'none'}"
            )
        dist = f" of {ep.dist.name}" if ep.dist is not None else ""
        found.append((ep.value, f"entry point {name!r}{dist}"))
    return found


class SkillRegistry:
    """The skills of one agent: where they come from and their current entries."""

    def __init__(
        self,
        ontology: Ontology,
        *,
        paths: Sequence[str] = (),
        entry_points: Sequence[str] = (),
        services: Sequence[ServiceSkillConfig] = (),
        condition_modules: Sequence[str] = (),
        conditions: ConditionRegistry | None = None,
        sensing_max_age: float | None = None,
        context: Mapping[str, object] | None = None,
    ) -> None:
        self.ontology = ontology
        self.paths = list(paths)
        self.entry_point_names = list(entry_points)
        self.services = list(services)
        self.condition_modules = list(condition_modules)
        self.conditions = conditions if conditions is not None else ConditionRegistry()
        self.sensing_max_age = sensing_max_age
        self.context = dict(context or {})
        """Keyword arguments offered to skill constructors that accept them (e.g. ``mesh``)."""
        self._entries: dict[str, SkillEntry] = {}
        self._classes: dict[str, type[Skill]] = {}
        self._lock = threading.Lock()  # load / reload may run in worker threads

    @classmethod
    def from_config(
        cls,
        config: AgentConfig,
        ontology: Ontology,
        *,
        context: Mapping[str, object] | None = None,
    ) -> SkillRegistry:
        return cls(
            ontology,
            paths=config.skills.paths,
            entry_points=config.skills.entry_points,
            services=config.services,
            condition_modules=config.conditions,
            sensing_max_age=config.sensing.max_age,
            context=context,
        )

    @property
    def entries(self) -> Mapping[str, SkillEntry]:
        return dict(self._entries)

    def skill_class(self, name: str) -> type[Skill]:
        return self._classes[name]

    def descriptions(self) -> list[SkillDescription]:
        return [e.description for e in self._entries.values()]

    def load(self) -> dict[str, SkillEntry]:
        """Import every skill and check it. Raises :class:`SkillLoadError`."""
        return self._build(fresh=False)

    def reload(self) -> dict[str, SkillEntry]:
        """Re-import every module and check again; returns the new entries (the old ones stay
        in place if anything fails). Raises :class:`SkillLoadError`."""
        return self._build(fresh=True)

    def shipped_terms(self) -> list[Path]:
        """The Turtle files the skills ship (:attr:`Skill.ontology`), in load order, once
        each. Imports the skills (as :meth:`load` does) without checking them, so an agent
        can teach these terms before the check. Raises :class:`SkillLoadError`."""
        with self._lock:
            loader = _Loader(fresh=False)
            refs = [(p, "config") for p in self.paths]
            refs += entry_point_skills(self.entry_point_names)
            found: list[Path] = []
            for ref, origin in refs:
                for skill_cls in loader.classes(ref, origin):
                    for name in skill_cls.ontology:
                        path = _beside(skill_cls, name)
                        if path not in found:
                            found.append(path)
            return found

    # ------------------------------------------------------------------ internals

    def _build(self, *, fresh: bool) -> dict[str, SkillEntry]:
        with self._lock:
            loader = _Loader(fresh=fresh)
            for ref in self.condition_modules:
                self._register_conditions(loader.module(ref, "conditions"), replace=fresh)
            refs = [(p, "config") for p in self.paths]
            refs += entry_point_skills(self.entry_point_names)
            classes: dict[str, tuple[type[Skill], str]] = {}
            for ref, origin in refs:
                for skill_cls in loader.classes(ref, origin):
                    self._add(classes, skill_cls, f"{ref} ({origin})")
            for service in self.services:
                skill_cls = external_skill(
                    service.description, service.service, goal_timeout=service.goal_timeout
                )
                self._add(classes, skill_cls, f"service {service.service!r} (config)")
            entries = {name: self._entry(c, source) for name, (c, source) in classes.items()}
            self._entries = entries
            self._classes = {name: c for name, (c, _) in classes.items()}
            return dict(entries)

    @staticmethod
    def _add(found: dict[str, tuple[type[Skill], str]], cls: type[Skill], source: str) -> None:
        name = cls.description.name
        if name in found and found[name][0] is not cls:
            raise SkillLoadError(
                f"two skills are called {name!r}: {found[name][1]} and {source}; "
                "rename one (SkillDescription.name)"
            )
        found[name] = (cls, source)

    def _entry(self, cls: type[Skill], source: str) -> SkillEntry:
        desc = cls.description
        if desc.sensing_max_age is None and self.sensing_max_age is not None:
            desc = msgspec.structs.replace(desc, sensing_max_age=self.sensing_max_age)
        try:
            check_description(desc, self.ontology, registry=self.conditions)
        except (SkillError, WmError, ValueError) as e:
            raise SkillLoadError(f"{source}: {e}") from None
        return SkillEntry(description=desc, factory=_factory(cls, self.context), source=source)

    def _register_conditions(self, module: ModuleType, *, replace: bool) -> None:
        found = [
            obj
            for obj in vars(module).values()
            if isinstance(obj, type)
            and obj.__module__ == module.__name__
            and isinstance(getattr(obj, "name", None), str)
            and callable(getattr(obj, "evaluate", None))
            and callable(getattr(obj, "symbolic", None))
            and not inspect.isabstract(obj)
        ]
        if not found:
            raise SkillLoadError(f"condition module {module.__name__!r} defines no condition class")
        for cls in found:
            self.conditions.register(cls, replace=replace)


def _beside(cls: type[Skill], name: str) -> Path:
    path = Path(name)
    if not path.is_absolute():
        path = Path(inspect.getfile(cls)).resolve().parent / path
    if not path.is_file():
        raise SkillLoadError(
            f"skill {cls.description.name!r} ({cls.__module__}) ships ontology file {name!r}, "
            f"but there is no {path}"
        )
    return path


def _factory(cls: type[Skill], context: Mapping[str, object]) -> Callable[[], Skill]:
    try:
        accepted = inspect.signature(cls).parameters
    except (TypeError, ValueError):
        return cls
    kwargs = {k: v for k, v in context.items() if k in accepted}
    return functools.partial(cls, **kwargs) if kwargs else cls


def _skill_classes(module: ModuleType) -> list[type[Skill]]:
    return [
        obj
        for obj in vars(module).values()
        if isinstance(obj, type)
        and issubclass(obj, Skill)
        and obj.__module__ == module.__name__
        and isinstance(getattr(obj, "description", None), SkillDescription)
        and not inspect.isabstract(obj)
    ]


_IMPORTS = threading.RLock()
"""Serialises what the import system does not: loading a skill file under a name of its own,
and reloading. It guards ``sys.modules``, which is the process's, so it is the process's too
(agents in one process load plug-ins from their own threads)."""


class _Loader:
    """Imports modules once per load; with ``fresh``, re-imports each one once."""

    def __init__(self, *, fresh: bool) -> None:
        self.fresh = fresh
        self._done: dict[str, ModuleType] = {}

    def module(self, ref: str, origin: str) -> ModuleType:
        target = ref.partition(":")[0]
        if target in self._done:
            return self._done[target]
        try:
            module = self._file(target) if is_file_reference(ref) else self._dotted(target)
        except SkillLoadError:
            raise
        except Exception as e:
            hint = ""
            if isinstance(e, ModuleNotFoundError) and target.startswith(f"{_STANDARD}."):
                hint = (
                    f"; the standard skills are named {_STANDARD}:<Class> (e.g. {_STANDARD}:Pick)"
                )
            raise SkillLoadError(
                f"cannot import {target!r} ({origin}): {type(e).__name__}: {e}{hint}"
            ) from e
        self._done[target] = module
        return module

    def classes(self, ref: str, origin: str) -> list[type[Skill]]:
        module = self.module(ref, origin)
        attr = ref.partition(":")[2]
        if not attr:
            found = _skill_classes(module)
            if not found:
                raise SkillLoadError(
                    f"{ref!r} ({origin}) defines no Skill subclass with a description"
                )
            return found
        obj = getattr(module, attr, None)
        if obj is None:
            raise SkillLoadError(
                f"{ref!r} ({origin}): module {module.__name__!r} has no {attr!r}"
                f"{did_you_mean(attr, [c.__name__ for c in _skill_classes(module)])}"
            )
        if not (isinstance(obj, type) and issubclass(obj, Skill)):
            raise SkillLoadError(f"{ref!r} ({origin}) is not a Skill subclass")
        if not isinstance(getattr(obj, "description", None), SkillDescription):
            raise SkillLoadError(f"{ref!r} ({origin}) has no SkillDescription `description`")
        return [obj]

    def _dotted(self, name: str) -> ModuleType:
        if not self.fresh:  # waits for an import another thread has under way
            return importlib.import_module(name)
        with _IMPORTS:
            module = sys.modules.get(name)
            if module is None:
                return importlib.import_module(name)
            _drop_bytecode(module)
            return importlib.reload(module)

    def _file(self, file: str) -> ModuleType:
        with _IMPORTS:  # another thread must never see the module half executed
            return self._load_file(file)

    def _load_file(self, file: str) -> ModuleType:
        path = Path(file)
        if not path.is_file():
            raise SkillLoadError(f"skill file {file!r} does not exist")
        digest = hashlib.sha1(str(path).encode(), usedforsecurity=False).hexdigest()[:10]
        name = f"skimesh_skills_{path.stem}_{digest}"
        if not self.fresh and name in sys.modules:
            return sys.modules[name]
        spec = importlib.util.spec_from_file_location(name, path)
        if spec is None or spec.loader is None:
            raise SkillLoadError(f"cannot load {file!r} as a Python module")
        module = importlib.util.module_from_spec(spec)
        old = sys.modules.get(name)
        sys.modules[name] = module  # dataclasses and pickling look modules up by name
        try:
            _drop_bytecode(module)
            spec.loader.exec_module(module)
        except BaseException:
            if old is None:
                sys.modules.pop(name, None)
            else:
                sys.modules[name] = old
            raise
        return module


def _drop_bytecode(module: ModuleType) -> None:
    """Remove the cached bytecode of ``module``'s source: its validity check compares the
    source's mtime in whole seconds, so a file edited twice in one second (same size) would
    otherwise reload stale code."""
    source = getattr(module, "__file__", None)
    if source and source.endswith(".py"):
        with contextlib.suppress(OSError, NotImplementedError, ValueError):
            Path(importlib.util.cache_from_source(source)).unlink(missing_ok=True)
