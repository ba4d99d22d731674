"""The vocabulary of a planning task: its predicates, types and objects, and the initial facts.

:class:`Vocabulary` reads the atoms of the skills' drafts and the goal into predicates
(:class:`PredicateNames`: the kind of each atom name and a PDDL-safe unique name), builds the
type tree from the classes of the actions' variables, picks the objects and their types, and
collects the initial facts from the world model, static ``is_C`` and ``owns`` facts included.
The rules are under **Types** in :mod:`task_agent.domain`.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from typing import Literal

from skill_agent import WorldView
from skill_agent.conditions import Atom, value_text
from wm_store.ontology import Ontology

from .._errors import DomainError
from ._model import ROOT_TYPE, GroundFact, Predicate, PredicateKind
from ._skills import Draft, element_is

__all__ = ["PredicateNames", "Vocabulary"]


class PredicateNames:
    """Atom names -> predicate kinds, and PDDL-safe unique names."""

    def __init__(self, ontology: Ontology) -> None:
        self.ontology = ontology
        self.predicates: dict[str, Predicate] = {}
        self._taken: set[str] = set()

    def kind(self, pred: str) -> tuple[PredicateKind | Literal["empty"], str]:
        """The kind of an atom name and its subject (relation, property or class name)."""
        onto = self.ontology
        if pred in onto.relations:
            return "relation", pred
        if "=" in pred and pred.split("=", 1)[0] in onto.data_properties:
            return "value", pred.split("=", 1)[0]
        for prefix, kind, known in (
            ("has_", "has", onto.data_properties),
            ("is_", "type", onto.classes),
            ("empty_", "empty", onto.relations),
        ):
            if pred.startswith(prefix) and pred[len(prefix) :] in known:
                return kind, pred[len(prefix) :]  # type: ignore[return-value]
        return "opaque", pred

    def declare(self, pred: str, kind: PredicateKind, arity: int) -> Predicate:
        found = self.predicates.get(pred)
        if found is not None:
            return found
        base = re.sub(r"[^A-Za-z0-9_]", "_", pred.replace("=", "_eq_")) or "p"
        base = base if base[0].isalpha() else f"p_{base}"
        pddl, n = base, 1
        while pddl.lower() in self._taken:
            n += 1
            pddl = f"{base}_{n}"
        self._taken.add(pddl.lower())
        found = Predicate(pred, kind, arity, pddl, static=kind in ("type", "owns"))
        self.predicates[pred] = found
        return found


class Vocabulary:
    """What the actions and the goal talk about, filled in by :meth:`predicates` then
    :meth:`types`; :meth:`init` then reads the initial facts."""

    def __init__(self, view: WorldView, drafts: list[Draft], goal_atoms: list[Atom]) -> None:
        self.view, self.onto = view, view.ontology
        self.drafts, self.goal_atoms = drafts, goal_atoms
        self.names = PredicateNames(self.onto)
        self.relations: set[str] = set()
        self.values: dict[str, set[str]] = {}
        self.has: set[str] = set()
        self.classes: set[str] = set()
        self.tree: dict[str, str] = {}
        self.objects: dict[str, str] = {}
        self.conflicts: set[str] = set()

    def predicates(self) -> None:
        atoms = [*self.goal_atoms, *(a for d in self.drafts for a in (*d.pre, *d.post))]
        opaque: dict[str, int] = {}
        for atom in atoms:
            kind, subject = self.names.kind(atom.predicate)
            if kind == "relation":
                self.relations.add(subject)
            elif kind == "empty":
                self.relations |= self.onto.subproperties(subject)
            elif kind == "value":
                self.values.setdefault(subject, set()).add(atom.predicate)
            elif kind == "has":
                self.has.add(subject)
            elif kind == "type":
                self.classes.add(subject)
            elif opaque.setdefault(atom.predicate, len(atom.args)) != len(atom.args):
                raise DomainError(f"condition atom '{atom.predicate}' is used with two arities")
        for r in sorted(self.relations):
            self.names.declare(r, "relation", 2)
        for preds in self.values.values():
            for p in sorted(preds):
                self.names.declare(p, "value", 1)
        for q in sorted(self.has):
            self.names.declare(f"has_{q}", "has", 1)
        for c in sorted(self.classes):
            self.names.declare(f"is_{c}", "type", 1)
        for p, n in sorted(opaque.items()):
            self.names.declare(p, "opaque", n)
        if any(d.owned for d in self.drafts):
            self.names.declare("owns", "owns", 2)

    def types(self, extra: Iterable[str]) -> None:
        param_classes = {c for d in self.drafts for c in d.variables.values()}
        for c in param_classes:
            up = self.onto.superclasses(c)[1:]
            self.tree[c] = next((a for a in up if a in param_classes), ROOT_TYPE)
        ids: set[str] = set(extra)
        for c in param_classes:
            ids |= {e.id for e in self.view.resolve_element(type=c)}
        for r in self.relations:
            for rel in self.view.query_relation(predicate=r):
                ids |= {rel.subject, rel.object}
        typed: dict[str, str] = {}  # by class: elements of one class get the same type
        for element_id in ids:
            element = self.view.find_element(element_id)
            if element is None:
                continue
            chosen = typed.get(element.type)
            if chosen is None:
                relevant = [a for a in self.onto.superclasses(element.type) if a in self.tree]
                # the type whose chain covers most of the relevant classes (then the nearest)
                chosen = typed[element.type] = max(
                    relevant,
                    key=lambda c: (len(set(self._chain(c)) & set(relevant)), -relevant.index(c)),
                    default=ROOT_TYPE,
                )
                self.conflicts |= set(relevant) - set(self._chain(chosen))
            self.objects[element_id] = chosen
        for c in sorted(self.conflicts):
            self.names.declare(f"is_{c}", "type", 1)
            self.classes.add(c)

    def _chain(self, t: str) -> list[str]:
        out = []
        while t != ROOT_TYPE:
            out.append(t)
            t = self.tree[t]
        return out

    def init(self) -> set[GroundFact]:
        facts: set[GroundFact] = set()
        for r in self.relations:
            for rel in self.view.query_relation(predicate=r):
                if rel.subject in self.objects and rel.object in self.objects:
                    facts.add((r, (rel.subject, rel.object)))
        for element_id in self.objects:
            element = self.view.get_element(element_id)
            for q, preds in self.values.items():
                text = value_text(element.properties.get(q))
                if text is not None and f"{q}={text}" in preds:
                    facts.add((f"{q}={text}", (element_id,)))
            facts |= {(f"has_{q}", (element_id,)) for q in self.has if q in element.properties}
            for c in self.classes:
                if self.onto.is_a(element.type, c):
                    facts.add((f"is_{c}", (element_id,)))
        for d in self.drafts:
            for var in d.owned:
                cls = d.variables[var]
                for h in d.agent.hardware:
                    if d.agent.robot and h in self.objects and element_is(self.view, h, cls):
                        facts.add(("owns", (d.agent.robot, h)))
        return facts

    # ------------------------------------------------------------------ for the actions

    def supers(self, r: str) -> list[str]:
        """The modeled proper super-properties of relation ``r``."""
        return sorted((self.onto.superproperties(r) & self.relations) - {r})

    def subs(self, r: str) -> list[str]:
        """The modeled sub-properties of relation ``r`` (``r`` included, if modeled)."""
        return sorted(self.onto.subproperties(r) & self.relations)

    def spatial(self) -> list[str]:
        """The modeled spatial relations."""
        return sorted(r for r in self.relations if self.onto.relation(r).spatial)
