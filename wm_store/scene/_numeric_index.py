"""Sorted indexes of numeric properties, per element type, for range filters in ``resolve``.

A :class:`~wm_store.protocol.PropertyFilter` such as ``mass lt 0.06`` over a class with a
thousand members would otherwise read every member's properties (a cache miss each on a large
scene). :class:`NumericIndexes` keeps, for each (asserted element type, property) that a query
has asked about, the members' numeric values in ascending order beside their ids, and answers
``lt`` / ``le`` / ``gt`` / ``ge`` with one bisection and a slice.

- An index is built on first use and then kept current by :class:`~wm_store.scene.SceneState`
  on every element put or removal (including undo); types are asserted types, so a class
  defined at run time needs nothing: ``resolve`` takes the subclass closure from the ontology
  at query time and reads one index per member type.
- Only ``int`` and ``float`` values are indexed (not ``bool``, not NaN): exactly the values the
  plain filter compares (``type(value) in (int, float)``; NaN never compares true).
- Elements in a state are replaced, never mutated in place; so are their ``properties``.
"""

from __future__ import annotations

from bisect import bisect_left, bisect_right
from collections.abc import Iterable, Mapping
from typing import TypeGuard

from wm_store.protocol import Element, Value

__all__ = ["RANGE_OPS", "NumericIndexes", "SortedValues", "indexable"]

RANGE_OPS = frozenset(("lt", "le", "gt", "ge"))
"""The comparators an index answers."""


def indexable(value: Value) -> TypeGuard[int | float]:
    """Whether ``value`` is one the indexes hold: an ``int`` or a non-NaN ``float``."""
    kind = type(value)
    return kind is int or (kind is float and value == value)


class SortedValues:
    """The values of one property over the members of one type, ascending, with their ids."""

    __slots__ = ("ids", "values")

    def __init__(self, pairs: Iterable[tuple[int | float, str]] = ()) -> None:
        ordered = sorted(pairs, key=lambda pair: pair[0])
        self.values: list[int | float] = [v for v, _ in ordered]
        self.ids: list[str] = [i for _, i in ordered]

    def __len__(self) -> int:
        return len(self.ids)

    def add(self, element_id: str, value: int | float) -> None:
        at = bisect_right(self.values, value)
        self.values.insert(at, value)
        self.ids.insert(at, element_id)

    def remove(self, element_id: str, value: int | float) -> None:
        values, ids = self.values, self.ids
        for at in range(bisect_left(values, value), len(values)):
            if ids[at] == element_id:
                del values[at], ids[at]
                return
            if values[at] != value:
                break
        # Not under its value: someone changed an element's properties in place. Never fail a
        # state change for that; drop the entry wherever it is.
        if element_id in ids:  # pragma: no cover - elements are replaced, not mutated
            at = ids.index(element_id)
            del values[at], ids[at]

    def select(self, op: str, bound: float) -> list[str]:
        """Ids whose value ``op`` ``bound`` (``op`` in :data:`RANGE_OPS`, ``bound`` not NaN)."""
        if op == "lt":
            return self.ids[: bisect_left(self.values, bound)]
        if op == "le":
            return self.ids[: bisect_right(self.values, bound)]
        if op == "gt":
            return self.ids[bisect_right(self.values, bound) :]
        if op == "ge":
            return self.ids[bisect_left(self.values, bound) :]
        raise ValueError(f"not a range comparator: {op!r}")


class NumericIndexes:
    """Every :class:`SortedValues` of one scene state, by type, then property."""

    def __init__(self, elements: Mapping[str, Element], by_type: Mapping[str, set[str]]) -> None:
        self._elements = elements
        self._by_type = by_type
        self._indexes: dict[str, dict[str, SortedValues]] = {}

    def __len__(self) -> int:
        """How many (type, property) indexes exist."""
        return sum(len(by_prop) for by_prop in self._indexes.values())

    def select(self, types: Iterable[str], prop: str, op: str, bound: float) -> list[str]:
        """Ids of the members of ``types`` whose ``prop`` ``op`` ``bound``, in no set order.

        Builds the missing indexes (types with no members need none). A NaN bound matches
        nothing, as in the plain comparison.
        """
        if bound != bound:
            return []
        found: list[str] = []
        for t in types:
            if t in self._by_type:
                found += self.index(t, prop).select(op, bound)
        return found

    def index(self, element_type: str, prop: str) -> SortedValues:
        by_prop = self._indexes.setdefault(element_type, {})
        index = by_prop.get(prop)
        if index is None:
            elements = self._elements
            pairs = (
                (value, i)
                for i in self._by_type.get(element_type, ())
                if indexable(value := elements[i].properties.get(prop))
            )
            index = by_prop[prop] = SortedValues(pairs)
        return index

    def element_put(self, previous: Element | None, element: Element) -> None:
        """Keep the indexes current: ``element`` replaces ``previous`` (``None``: new)."""
        if not self._indexes:
            return
        if previous is not None:
            old = self._indexes.get(previous.type)
            if old:
                same_type = previous.type == element.type
                for prop, index in old.items():
                    before = previous.properties.get(prop)
                    if same_type and element.properties.get(prop) is before:
                        continue
                    if indexable(before):
                        index.remove(element.id, before)
                    if same_type and indexable(after := element.properties.get(prop)):
                        index.add(element.id, after)
                if same_type:
                    return
        new = self._indexes.get(element.type)
        if new:
            for prop, index in new.items():
                if indexable(value := element.properties.get(prop)):
                    index.add(element.id, value)

    def element_dropped(self, element: Element) -> None:
        by_prop = self._indexes.get(element.type)
        if by_prop:
            for prop, index in by_prop.items():
                if indexable(value := element.properties.get(prop)):
                    index.remove(element.id, value)
