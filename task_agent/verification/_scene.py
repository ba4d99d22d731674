"""The private world of task verification: a :class:`SceneView` over a copy of the world model,
and what parallel branches change in it (:func:`changes`, :func:`clashes`).

The symbolic simulation of :mod:`task_agent.verification` applies predicted effects to a
:class:`~wm_store.scene.SceneState` copied from the caller's view (:func:`scene_copy`), never to
the view itself. :func:`changes` lists what one branch changed that another branch could change
differently, as *facts*:

- ``("prop", id, q)``   -> the new value (None: deleted)
- ``("parent", id)``    -> the new spatial parent, ``"<id> (<predicate>)"`` (None: none)

Two branches *clash* on a fact both change to different values: which one wins depends on
which finishes last. (A relation is true or false: two branches starting from one state can
only change it the same way; a spatial relation moves its object, hence ``parent``.) Effects
that cannot coexist otherwise (a second ``at`` where the ontology allows one) fail when the
branches' effects are combined. Pure: no I/O.
"""

from __future__ import annotations

from skill_agent import WorldView
from wm_store.ontology import Ontology
from wm_store.protocol import Element, Query, Relation
from wm_store.scene import SceneState, match_relations, resolve

__all__ = ["SceneFact", "SceneView", "changes", "clashes", "scene_copy"]

SceneFact = tuple[str, ...]
"""What a branch may change: ``("prop", id, q)`` or ``("parent", id)`` (see the module doc)."""


class SceneView:
    """A :class:`~skill_agent.WorldView` over a private :class:`SceneState`."""

    def __init__(self, state: SceneState, ontology: Ontology) -> None:
        self.state, self._ontology = state, ontology

    @property
    def ontology(self) -> Ontology:
        return self._ontology

    def get_element(self, element_id: str) -> Element:
        element = self.state.get(element_id)
        if element is None:
            raise KeyError(element_id)
        return element

    def find_element(self, element_id: str) -> Element | None:
        return self.state.get(element_id)

    def resolve_element(self, query: Query | None = None, *, type: str = "") -> list[Element]:
        return resolve(self.state, self._ontology, query or Query(type=type))

    def query_relation(
        self, subject: str = "", predicate: str = "", obj: str = ""
    ) -> list[Relation]:
        return match_relations(self.state, self._ontology, subject, predicate, obj)


def scene_copy(view: WorldView) -> SceneState:
    """A private copy of the elements and relations ``view`` shows."""
    if isinstance(view, SceneView):
        return view.state.copy()
    state = SceneState()
    state.set_spatial_predicates(n for n, r in view.ontology.relations.items() if r.spatial)
    for element in view.resolve_element():
        state.put_element(element)
    for rel in view.query_relation():
        state.add_relation(rel)
    return state


def changes(before: SceneState, after: SceneState) -> dict[SceneFact, object]:
    """The facts ``after`` changed with respect to ``before`` (see the module doc)."""
    out: dict[SceneFact, object] = {}
    for eid, element in after.elements.items():
        prior = before.get(eid)
        was = prior.properties if prior is not None else {}
        for name in set(was) | set(element.properties):
            if was.get(name) != element.properties.get(name):
                out[("prop", eid, name)] = element.properties.get(name)
        p0, p1 = before.parent(eid), after.parent(eid)
        if p0 != p1:
            out[("parent", eid)] = None if p1 is None else f"{p1.subject} ({p1.predicate})"
    return out


def _text(fact: SceneFact, a: object, b: object, names: tuple[str, str]) -> str:
    first, second = names
    if fact[0] == "parent":
        into = (a or "nothing", b or "nothing")
        return f"where {fact[1]} goes ({first}: into {into[0]}; {second}: into {into[1]})"
    return f"{fact[1]}.{fact[2]} ({first} sets {a!r}, {second} {b!r})"


def clashes(
    a: dict[SceneFact, object], b: dict[SceneFact, object], names: tuple[str, str]
) -> list[str]:
    """The facts two branches' :func:`changes` set differently, as text, in a stable order."""
    return [_text(f, a[f], b[f], names) for f in sorted(a.keys() & b.keys()) if a[f] != b[f]]
