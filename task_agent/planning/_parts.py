"""The pieces a decomposed solve works with, found without a planner: the goal's independent
:func:`parts`, the :class:`FactGraph` of a state (which elements facts connect) and the
:func:`focus` of a part (the elements near it in that graph).

A *part* is a set of goal literals that share no element with the rest of the goal (literals
connected through a shared element are one part: two gears into one kit box, a box and its
lid). The *fact graph* links the elements named together by a fact (``contain(box, gear)``,
``at(robot, station)``, ``owns(robot, gripper)``). An element named by more than ``hub``
facts (a depot where every robot stands, a shelf of forty parts) is a *hub*: it is kept
when reached but not crossed, so the neighbourhood of one robot does not take in every other
robot through the floor they share. Pure.
"""

from __future__ import annotations

from collections import defaultdict, deque
from collections.abc import Iterable, Mapping, Sequence

from ..domain import GroundFact, Lit

__all__ = ["FactGraph", "parts"]


def parts(goal: Sequence[Lit]) -> list[tuple[Lit, ...]]:
    """The goal's literals grouped into parts (see the module doc), in the goal's order."""
    parent = list(range(len(goal)))

    def root(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    owner: dict[str, int] = {}
    for i, lit in enumerate(goal):
        for element in lit.args:
            j = owner.setdefault(element, i)
            parent[root(i)] = root(j)
    groups: dict[int, list[Lit]] = {}
    for i, lit in enumerate(goal):
        groups.setdefault(root(i), []).append(lit)
    return [tuple(g) for g in groups.values()]


class FactGraph:
    """Which elements the facts of a state name together (see the module doc)."""

    def __init__(self, facts: Iterable[GroundFact], objects: Mapping[str, str]) -> None:
        self.objects = objects
        self.edges: dict[str, set[str]] = defaultdict(set)
        self.degree: dict[str, int] = defaultdict(int)
        self.add(facts)

    def add(self, facts: Iterable[GroundFact]) -> None:
        """Link what ``facts`` name too (a graph only grows: a deleted fact keeps its link,
        which can only widen a focus)."""
        for _, args in facts:
            if len(args) < 2:
                continue
            named = [a for a in args if a in self.objects]
            for a in named:
                self.degree[a] += 1
                self.edges[a].update(b for b in named if b != a)

    def distances(self, seeds: Iterable[str], *, depth: int, hub: int) -> dict[str, int]:
        """Hops from the nearest of ``seeds`` to each element within ``depth`` hops; hubs are
        reached but not crossed (a seed is always crossed)."""
        found = dict.fromkeys(seeds, 0)
        todo = deque(found)
        while todo:
            element = todo.popleft()
            d = found[element]
            if d >= depth or (d > 0 and self.degree[element] > hub):
                continue
            for other in self.edges.get(element, ()):
                if other not in found:
                    found[other] = d + 1
                    todo.append(other)
        return found

    def focus(self, seeds: Iterable[str], *, depth: int, hub: int) -> set[str]:
        """``seeds`` and every element within ``depth`` hops of them (hubs not crossed)."""
        return set(self.distances(seeds, depth=depth, hub=hub))
