"""The minimum-cardinality report of a scene (``CheckCardinality``, ``skimesh wm check``).

The store enforces *maximum* cardinalities on every write. It cannot enforce *minimums* per
write: a robot is added before its arm, a microwave before its door. So they are reported:
:func:`min_cardinality_violations` lists every element with fewer relations than a minimum
cardinality of its class (or a superclass) asks for, counting sub-properties and, for a
qualified restriction, objects of its class or below.

It reads the state only through its indexes: the elements of classes that carry a minimum
(with their subclasses), then each one's outgoing relations.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

from wm_store._errors import ElementNotFoundError
from wm_store.protocol import CardinalityViolation
from wm_store.scene._query import id_sort_key
from wm_store.scene._state import SceneState

if TYPE_CHECKING:
    from wm_store.ontology import Ontology

__all__ = ["min_cardinality_violations"]


def min_cardinality_violations(
    state: SceneState, ontology: Ontology, ids: Sequence[str] = ()
) -> tuple[int, list[CardinalityViolation]]:
    """``(elements checked, violations)`` for ``ids`` (default: every element).

    Violations come in natural id order, one per element and unmet restriction. Raises
    :class:`~wm_store.ElementNotFoundError` naming any id that is not in the state.
    """
    if ids:
        missing = [i for i in ids if i not in state]
        if missing:
            raise ElementNotFoundError(f"no element(s) {', '.join(missing)}")
        checked = len(set(ids))
        candidates = sorted(set(ids), key=id_sort_key)
    else:
        checked = len(state.elements)
        bounded = [t for t in state.types() if any(r.minimum for r in ontology.restrictions(t))]
        candidates = sorted(state.ids_of_types(bounded), key=id_sort_key)
    violations: list[CardinalityViolation] = []
    for element_id in candidates:
        element = state.elements[element_id]
        existing = [
            (r.predicate, state.elements[r.object].type) for r in state.match_relations(element_id)
        ]
        for shortfall in ontology.check_min_cardinality(element.type, existing):
            r = shortfall.restriction
            violations.append(
                CardinalityViolation(
                    element=element_id,
                    type=element.type,
                    relation=r.relation,
                    required=r.minimum or 0,
                    present=shortfall.actual,
                    on_class=r.on_class or "",
                    declared_on=r.declared_on,
                    message=f"{element_id}: {shortfall.message}",
                )
            )
    return checked, violations
