"""Reasoner plug-ins (SkiROS "discrete reasoners") and the set that loads them.

A reasoner interprets the typed data of elements (poses, sizes, colours…) and answers questions
the symbolic graph cannot: where is X relative to Y, is X inside Y, which known object is this.
It is bound to one *scene view* — a :class:`~wm_store.scene.SceneState`, the store's own or a
client replica's — and an ontology, and it only reads them: every method is pure, synchronous
and quick, so callers decide whether to run it on the loop or in a thread.

Plug-ins are factories ``(view, ontology) -> Reasoner`` (a reasoner class is its own factory),
published by a distribution under the entry-point group ``skimesh.reasoners``::

    [project.entry-points."skimesh.reasoners"]
    grasp = "my_pkg.grasp:GraspReasoner"

:class:`ReasonerSet` collects the built-in reasoners, the entry points and explicitly given
factories (later layers replace earlier ones of the same name) and binds them to a view.
It is an ordinary instance: nothing is registered process-wide.

Errors (all :class:`~wm_store.WmError`)::

    PropertyValueError
    ├── MissingDataError   an element lacks the typed data a question needs (e.g. no pose)
    └── FrameCycleError    pose frames refer to each other in a loop
    ReasonerError          a plug-in cannot be loaded, or two plug-ins share a name

The first two keep the wire code of :class:`~wm_store.PropertyValueError`, so they
cross the store boundary as that class.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator, Mapping
from importlib.metadata import EntryPoint, entry_points
from typing import TYPE_CHECKING, Protocol, runtime_checkable

from wm_store._errors import PropertyValueError, WmError
from wm_store.protocol import Value
from wm_store.scene import SceneState

if TYPE_CHECKING:
    from wm_store.ontology import Ontology

__all__ = [
    "ENTRY_POINT_GROUP",
    "FrameCycleError",
    "MissingDataError",
    "Reasoner",
    "ReasonerError",
    "ReasonerFactory",
    "ReasonerSet",
    "builtin_factories",
]

ENTRY_POINT_GROUP = "skimesh.reasoners"


class MissingDataError(PropertyValueError):
    """An element lacks the typed data (pose, size…) a reasoner needs for the question."""


class FrameCycleError(PropertyValueError):
    """Pose frames refer to each other in a loop, so no world pose exists."""


class ReasonerError(WmError):
    """A reasoner plug-in cannot be loaded, does not fit the protocol, or clashes by name."""

    code = "reasoner_error"


@runtime_checkable
class Reasoner(Protocol):
    """What every reasoner offers; concrete reasoners add their own query methods
    (e.g. :meth:`SpatialReasoner.relative_pose`)."""

    @property
    def name(self) -> str:
        """Unique name (``"spatial"``); the key a client looks the reasoner up by."""
        ...

    @property
    def properties_handled(self) -> frozenset[str]:
        """Data properties whose values this reasoner interprets."""
        ...

    @property
    def data_codes(self) -> frozenset[str]:
        """What :meth:`get_data` can derive (SkiROS ``get_code``), e.g. ``"world_pose"``."""
        ...

    @property
    def relations_computed(self) -> frozenset[str]:
        """Relations :meth:`compute_relations` can decide from typed data."""
        ...

    def get_data(self, element_id: str, code: str) -> Value:
        """Derived typed data of an element. Raises ``ValidationError`` for an unknown code,
        ``ElementNotFoundError`` for an unknown id, ``MissingDataError`` if data is lacking."""
        ...

    def compute_relations(self, subject: str, obj: str) -> frozenset[str]:
        """Which of :attr:`relations_computed` hold from ``subject`` to ``obj``."""
        ...


ReasonerFactory = Callable[[SceneState, "Ontology"], Reasoner]
"""Builds a reasoner bound to a view; a reasoner class taking ``(view, ontology)`` is one."""


def builtin_factories() -> dict[str, ReasonerFactory]:
    """The reasoners shipped with ``wm_store``."""
    from wm_store.reasoners._similarity import SimilarityReasoner
    from wm_store.reasoners._spatial import SpatialReasoner

    return {"spatial": SpatialReasoner, "similarity": SimilarityReasoner}


class ReasonerSet(Mapping[str, ReasonerFactory]):
    """Named reasoner factories; :meth:`bind` instantiates them over a scene view."""

    def __init__(self, factories: Mapping[str, ReasonerFactory] | None = None) -> None:
        self._factories: dict[str, ReasonerFactory] = dict(factories or {})

    @classmethod
    def load(
        cls,
        extra: Mapping[str, ReasonerFactory] | None = None,
        *,
        builtins: bool = True,
        group: str = ENTRY_POINT_GROUP,
        discover: Callable[[str], Iterable[EntryPoint]] | None = None,
    ) -> ReasonerSet:
        """Built-ins, then the entry points of ``group``, then ``extra``; a later layer replaces
        an earlier one of the same name. ``discover`` replaces the entry-point lookup (tests).

        Imports the plug-in modules (may block on disk). Raises :class:`ReasonerError` if an
        entry point fails to import, is not callable, or two entry points share a name.
        """
        found: dict[str, ReasonerFactory] = builtin_factories() if builtins else {}
        plugins: dict[str, ReasonerFactory] = {}
        points = discover(group) if discover is not None else entry_points(group=group)
        for point in sorted(points, key=lambda p: (p.name, p.value)):
            if point.name in plugins:
                raise ReasonerError(
                    f"two {group!r} entry points are named {point.name!r} "
                    f"(the second is {point.value!r}); uninstall or rename one"
                )
            try:
                factory = point.load()
            except Exception as exc:
                raise ReasonerError(
                    f"reasoner plug-in {point.name!r} ({point.value}) failed to load: "
                    f"{type(exc).__name__}: {exc}"
                ) from exc
            if not callable(factory):
                raise ReasonerError(
                    f"reasoner plug-in {point.name!r} ({point.value}) is not callable; "
                    "point the entry point at a class or factory taking (view, ontology)"
                )
            plugins[point.name] = factory
        found.update(plugins)
        found.update(extra or {})
        return cls(found)

    def __getitem__(self, name: str) -> ReasonerFactory:
        try:
            return self._factories[name]
        except KeyError:
            raise ReasonerError(
                f"no reasoner {name!r}; known: {', '.join(sorted(self._factories)) or 'none'}"
            ) from None

    def __iter__(self) -> Iterator[str]:
        return iter(sorted(self._factories))

    def __len__(self) -> int:
        return len(self._factories)

    def bind(self, view: SceneState, ontology: Ontology) -> dict[str, Reasoner]:
        """One reasoner of each kind over ``view``, by name. Raises :class:`ReasonerError` if a
        factory's product does not follow :class:`Reasoner` or names itself differently."""
        bound: dict[str, Reasoner] = {}
        for name in self:
            reasoner = self._factories[name](view, ontology)
            if not isinstance(reasoner, Reasoner):
                raise ReasonerError(
                    f"reasoner {name!r} built a {type(reasoner).__name__}, which lacks part of "
                    "the Reasoner protocol (name, properties_handled, data_codes, "
                    "relations_computed, get_data, compute_relations)"
                )
            if reasoner.name != name:
                raise ReasonerError(
                    f"reasoner registered as {name!r} calls itself {reasoner.name!r}; "
                    "make the entry-point name and the reasoner's name agree"
                )
            bound[name] = reasoner
        return bound
