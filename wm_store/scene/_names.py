"""Element names: an element is named by its id (store-assigned ``<Type>-<n>``) or its label
(free text), and every name names one element.

Rules, enforced by :func:`~wm_store.scene.apply_transaction` for added elements, relabelled
ones and explicit ids:

- **no name is both an id and a label**: a label equal to another element's id, or an
  explicit id equal to another element's label, is refused
  (:class:`~wm_store.NameConflictError`, naming both elements);
- **labels are unique within what they name**: two scene elements (everything that is not
  an agent or a skill) never share a label, nor do two agents; skills are named per agent
  (every agent has its ``pick``), so their labels repeat (:class:`~wm_store.DuplicateLabelError`,
  naming the element that has the label already);
- **ids never collide with labels**: an element labelled like an id of its own class
  (``Gear-3`` on a Gear) gets that id when it is fresh, and an assigned id skips every
  ``<Type>-<n>`` that is an element's label, now or later in the same transaction.

:class:`NameGuard` holds the per-transaction state of these rules; :func:`display_name` is
how messages and listings name an element.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING

from wm_store._errors import DuplicateIdError, DuplicateLabelError, NameConflictError
from wm_store.protocol import Element
from wm_store.scene._state import SceneState, parse_id

if TYPE_CHECKING:
    from wm_store.ontology import Ontology

__all__ = ["NameGuard", "check_explicit_form", "display_name", "label_namespace"]

_AGENT, _SKILL = "Agent", "Skill"


def display_name(element: Element | None, element_id: str = "") -> str:
    """How to name an element to a person: its label, with its id in parentheses where the two
    differ (``Pulley-4 (Gear-1)``); the id alone when it has no label; ``element_id`` when
    ``element`` is None (an element that is not, or no longer, in the world model)."""
    if element is None:
        return element_id
    if not element.label or element.label == element.id:
        return element.id
    return f"{element.label} ({element.id})"


def label_namespace(ontology: Ontology, cls: str) -> str:
    """Where a label of an element of class ``cls`` must be unique: ``agent``, ``scene``, or
    ``""`` (a skill: labels repeat, one per agent)."""
    known = ontology.classes
    if cls in known:
        if _SKILL in known and ontology.is_a(cls, _SKILL):
            return ""
        if _AGENT in known and ontology.is_a(cls, _AGENT):
            return "agent"
    return "scene"


class NameGuard:
    """The naming rules over one transaction (see the module doc)."""

    def __init__(self, state: SceneState, counters: dict[str, int], labels: Iterable[str]) -> None:
        self.state = state
        self.start = counters
        """The counters before the transaction: ids at or under them may have been used."""
        self.pending = {label for label in labels if label}
        """Labels the transaction writes: assigned ids skip them."""
        self.assigned: set[str] = set()

    def _named(self, element_id: str) -> str:
        return display_name(self.state.get(element_id), element_id)

    def new_id(self, element_type: str, label: str) -> str:
        """The id of a new element of ``element_type`` labelled ``label``."""
        own = parse_id(label)
        if (
            own is not None
            and own[0] == element_type
            and own[1] > self.start.get(element_type, 0)
            and label not in self.state
            and label not in self.assigned
        ):
            return self._take(label)
        n = self.state.counters.get(element_type, 0) + 1
        while True:
            candidate = f"{element_type}-{n}"
            if (
                candidate not in self.state
                and candidate not in self.assigned
                and (candidate == label or candidate not in self.pending)
                and not self.state.ids_with_label(candidate)
            ):
                return self._take(candidate)
            n += 1

    def explicit_id(self, element_id: str) -> str:
        """Check an explicit id (its form and freshness are checked by the caller)."""
        holders = sorted(self.state.ids_with_label(element_id))
        if holders:
            raise NameConflictError(
                f"id {element_id!r} is the label of {self._named(holders[0])}: a name names "
                "one element; give another id, or none (the store assigns one)"
            )
        return self._take(element_id)

    def _take(self, element_id: str) -> str:
        self.assigned.add(element_id)
        return element_id

    def check_label(
        self, ontology: Ontology, element_id: str, element_type: str, label: str
    ) -> None:
        """Refuse ``label`` for the element ``element_id`` if another element is named so
        (``ontology``: the transaction's, which tells agents and skills)."""
        if not label:
            return
        what = f"{element_type} {element_id}"
        if label != element_id and label in self.state:
            raise NameConflictError(
                f"label {label!r} of the {what} is the id of {self._named(label)}: a name "
                "names one element; choose another label (one not of the form <Type>-<n>, "
                f"or {element_id!r} itself)"
            )
        space = label_namespace(ontology, element_type)
        if not space:
            return
        for other in sorted(self.state.ids_with_label(label)):
            if other == element_id:
                continue
            element = self.state.elements[other]
            if label_namespace(ontology, element.type) == space:
                raise DuplicateLabelError(
                    f"label {label!r} of the {what} is already the label of "
                    f"{display_name(element)}: labels are unique (an agent's among agents, "
                    "any other element's among the scene); choose another label"
                )


def check_explicit_form(element_type: str, explicit: str, used: int, state: SceneState) -> None:
    """An explicit id must be ``<element_type>-<n>``, fresh and never used before."""
    parsed = parse_id(explicit)
    if parsed is None or parsed[0] != element_type:
        raise DuplicateIdError(f"explicit id {explicit!r} must have the form {element_type}-<n>")
    if explicit in state or parsed[1] <= used:
        raise DuplicateIdError(
            f"id {explicit!r} is taken or was used before (ids are never reused); "
            f"the next free one is {element_type}-{used + 1}"
        )
