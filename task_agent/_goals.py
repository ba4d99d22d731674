"""Goals: world-model facts the task should make true, as typed literals.

A goal is a conjunction of literals over element ids::

    contain(KitBox-1, Gear-3) and contain(KitBox-1, Gear-5)
    not contain(Tray-1, MealBox-1), doorOpen(Microwave-1) = true
    heating(Microwave-1)                  # a boolean property: "= true" is implied
    contain("kit box 1", Gear-3)          # a label, quoted when it has spaces
    partNumber(Gear-3) != "G-100"

Literals are separated by ``and``, ``,`` or ``&``. A *relation* literal takes two elements and
may be negated (``not``, or ``= false``); a *property* literal takes one element and a
boolean, integer or text value (``!=`` negates). Numeric comparisons are not goals the planner
can reach (skills predict no numbers), so ``= 2.5`` is refused.

:func:`parse_goal` reads text, :func:`check_goal` checks (and resolves labels in) literals that
arrived as Structs, :func:`goal_from_conditions` takes skill conditions over element ids. All
three raise :class:`~task_agent.GoalParseError` naming the closest element, relation or
property, or the expected arity, and the column in the text. The parser is ``_goal_text``.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import TypeAlias

import msgspec

from skill_agent import WorldView
from skill_agent.conditions import Atom
from skill_agent.protocol import AndCond, Condition, NotCond, PropertyCond, RelationCond
from wm_store import ValidationError
from wm_store.ontology import did_you_mean
from wm_store.protocol import Query

from ._errors import GoalParseError

__all__ = [
    "Goal",
    "GoalChecker",
    "GoalLiteral",
    "PropertyGoal",
    "RelationGoal",
    "Scalar",
    "check_goal",
    "goal_from_conditions",
    "literal_atom",
]

Scalar: TypeAlias = bool | int | str


class RelationGoal(msgspec.Struct, tag="relation", tag_field="goal", frozen=True, kw_only=True):
    """``predicate(subject, object)`` holds (``holds=False``: does not)."""

    predicate: str
    subject: str
    object: str
    holds: bool = True

    def __str__(self) -> str:
        return f"{'' if self.holds else 'not '}{self.predicate}({self.subject}, {self.object})"


class PropertyGoal(msgspec.Struct, tag="property", tag_field="goal", frozen=True, kw_only=True):
    """``element.property == value`` (``holds=False``: ``!=``)."""

    element: str
    property: str
    value: Scalar = True
    holds: bool = True

    def __str__(self) -> str:
        value = _text(self.value)
        return f"{self.property}({self.element}) {'=' if self.holds else '!='} {value}"


GoalLiteral: TypeAlias = RelationGoal | PropertyGoal


class Goal(msgspec.Struct, frozen=True, kw_only=True):
    """A conjunction of literals over element ids."""

    literals: tuple[GoalLiteral, ...]

    def __str__(self) -> str:
        return " and ".join(str(lit) for lit in self.literals)

    def elements(self) -> set[str]:
        """The element ids the goal names."""
        out: set[str] = set()
        for lit in self.literals:
            out |= {lit.subject, lit.object} if isinstance(lit, RelationGoal) else {lit.element}
        return out


def _text(value: Scalar) -> str:
    """A value as :func:`skill_agent.conditions.symbolic` names it (``true``, ``3``, ``abc``)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    return str(value)


def literal_atom(lit: GoalLiteral) -> Atom:
    """The planner atom of a literal, named as skill conditions name theirs."""
    if isinstance(lit, RelationGoal):
        return Atom(lit.predicate, (lit.subject, lit.object), lit.holds)
    return Atom(f"{lit.property}={_text(lit.value)}", (lit.element,), lit.holds)


# --------------------------------------------------------------------------- checking


class GoalChecker:
    """Resolves element references and checks names against one world-model view."""

    def __init__(self, view: WorldView) -> None:
        self.view = view
        self.ontology = view.ontology
        self._all: list[str] | None = None

    def element(self, ref: str, column: int = 0) -> str:
        if self.view.find_element(ref) is not None:
            return ref
        labelled = self.view.resolve_element(Query(label=ref))
        found = sorted(e.id for e in labelled)
        if len(found) > 1:  # an agent shares its robot's label: the goal means the robot
            found = sorted(e.id for e in labelled if not self._agent_or_skill(e.type)) or found
        if len(found) == 1:
            return found[0]
        if found:
            raise GoalParseError(
                f"the label {ref!r} is ambiguous: {', '.join(found[:8])}; write an id instead",
                column=column,
            )
        if self._all is None:  # element names, not skills' (a goal never names a skill)
            onto = self.ontology
            elements = [
                e
                for e in self.view.resolve_element(Query())
                if not ("Skill" in onto.classes and onto.is_a(e.type, "Skill"))
            ]
            self._all = [e.id for e in elements] + [e.label for e in elements if e.label]
        raise GoalParseError(
            f"unknown element {ref!r} (neither an id nor a label in the world model)"
            f"{did_you_mean(ref, self._all)}",
            column=column,
        )

    def _agent_or_skill(self, cls: str) -> bool:
        onto = self.ontology
        return any(c in onto.classes and onto.is_a(cls, c) for c in ("Agent", "Skill"))

    def kind(self, name: str, column: int = 0) -> str:
        """``relation`` or ``property``."""
        if name in self.ontology.relations:
            return "relation"
        if name in self.ontology.data_properties:
            return "property"
        names = [*self.ontology.relations, *self.ontology.data_properties]
        raise GoalParseError(
            f"unknown relation or property {name!r}{did_you_mean(name, names)}", column=column
        )

    def relation(self, lit: RelationGoal, column: int = 0) -> RelationGoal:
        s, o = self.element(lit.subject, column), self.element(lit.object, column)
        info = self.ontology.relation(lit.predicate)
        if not info.abstract:
            s_type, o_type = self.view.get_element(s).type, self.view.get_element(o).type
            try:
                self.ontology.check_relation(s_type, lit.predicate, o_type)
            except ValidationError as exc:
                raise GoalParseError(f"{lit}: {exc}", column=column) from None
        return RelationGoal(predicate=lit.predicate, subject=s, object=o, holds=lit.holds)

    def property(self, lit: PropertyGoal, column: int = 0) -> PropertyGoal:
        element = self.element(lit.element, column)
        if isinstance(lit.value, float):  # a Struct from the wire may still carry one
            raise GoalParseError(
                f"{lit}: numeric goals are not supported (skills predict no numbers); "
                "use a boolean, integer or text value",
                column=column,
            )
        try:
            self.ontology.check_property(
                self.view.get_element(element).type, lit.property, lit.value
            )
        except ValidationError as exc:
            raise GoalParseError(f"{lit}: {exc}", column=column) from None
        return msgspec.structs.replace(lit, element=element)

    def literal(self, lit: GoalLiteral, column: int = 0) -> GoalLiteral:
        if isinstance(lit, RelationGoal):
            if self.kind(lit.predicate, column) != "relation":
                raise GoalParseError(
                    f"{lit.predicate!r} is a property, not a relation", column=column
                )
            return self.relation(lit, column)
        if self.kind(lit.property, column) != "property":
            raise GoalParseError(f"{lit.property!r} is a relation, not a property", column=column)
        return self.property(lit, column)


def check_goal(goal: Goal | Iterable[GoalLiteral], view: WorldView) -> Goal:
    """The goal with labels resolved to ids, every name checked; GoalParseError otherwise."""
    literals = goal.literals if isinstance(goal, Goal) else tuple(goal)
    if not literals:
        raise GoalParseError("the goal is empty: give at least one fact")
    checker = GoalChecker(view)
    return Goal(literals=tuple(checker.literal(lit) for lit in literals))


def goal_from_conditions(conds: Sequence[Condition], view: WorldView) -> Goal:
    """A goal from skill conditions written over element ids (relations, ``eq``/``ne``
    property conditions, their negations and conjunctions)."""
    out: list[GoalLiteral] = []

    def add(cond: Condition, holds: bool) -> None:
        match cond:
            case AndCond(items=items) if holds:
                for item in items:
                    add(item, True)
            case NotCond(item=item):
                add(item, not holds)
            case RelationCond(subject=s, predicate=p, object=o, holds=h):
                out.append(RelationGoal(predicate=p, subject=s, object=o, holds=h == holds))
            case PropertyCond(param=x, property=q, op="eq" | "ne" as op, value=v) if isinstance(
                v, bool | int | str
            ):
                out.append(
                    PropertyGoal(element=x, property=q, value=v, holds=(op == "eq") == holds)
                )
            case _:
                raise GoalParseError(
                    f"cannot use {type(cond).__name__} as a goal: goals are relations and "
                    "boolean/integer/text property values, in conjunctions"
                )

    for cond in conds:
        add(cond, True)
    return check_goal(out, view)
