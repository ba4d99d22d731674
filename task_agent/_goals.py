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
property, or the expected arity, and the column in the text.
"""

from __future__ import annotations

import re
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
    "GoalLiteral",
    "PropertyGoal",
    "RelationGoal",
    "Scalar",
    "check_goal",
    "goal_from_conditions",
    "literal_atom",
    "parse_goal",
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


class _Checker:
    """Resolves element references and checks names against one world-model view."""

    def __init__(self, view: WorldView) -> None:
        self.view = view
        self.ontology = view.ontology
        self._all: list[str] | None = None

    def element(self, ref: str, column: int = 0) -> str:
        if self.view.find_element(ref) is not None:
            return ref
        found = sorted(e.id for e in self.view.resolve_element(Query(label=ref)))
        if len(found) == 1:
            return found[0]
        if found:
            raise GoalParseError(
                f"the label {ref!r} is ambiguous: {', '.join(found[:8])}; write an id instead",
                column=column,
            )
        if self._all is None:
            elements = self.view.resolve_element(Query())
            self._all = [e.id for e in elements] + [e.label for e in elements if e.label]
        raise GoalParseError(
            f"unknown element {ref!r} (neither an id nor a label in the world model)"
            f"{did_you_mean(ref, self._all)}",
            column=column,
        )

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
    checker = _Checker(view)
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


# --------------------------------------------------------------------------- parsing

_TOKEN = re.compile(
    r"""(?P<ws>\s+)
      | (?P<string>"[^"]*"|'[^']*')
      | (?P<number>-?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?)
      | (?P<name>[A-Za-z_][A-Za-z0-9_.:-]*)
      | (?P<op>!=|==|=|\(|\)|,|&&|&|!)
    """,
    re.VERBOSE,
)


class _Token(msgspec.Struct, frozen=True):
    kind: str
    text: str
    column: int


def _tokens(text: str) -> list[_Token]:
    out, pos = [], 0
    while pos < len(text):
        m = _TOKEN.match(text, pos)
        if m is None:
            raise GoalParseError(
                f"unexpected character {text[pos]!r} at column {pos + 1}", column=pos + 1
            )
        kind = m.lastgroup or ""
        if kind != "ws":
            out.append(_Token(kind, m.group(), pos + 1))
        pos = m.end()
    out.append(_Token("end", "", len(text) + 1))
    return out


class _Parser:
    def __init__(self, text: str, view: WorldView) -> None:
        self.tokens = _tokens(text)
        self.i = 0
        self.check = _Checker(view)

    @property
    def tok(self) -> _Token:
        return self.tokens[self.i]

    def expect(self, text: str, what: str) -> _Token:
        tok = self.tok
        if tok.text != text:
            found = "the end of the goal" if tok.kind == "end" else repr(tok.text)
            raise GoalParseError(
                f"expected {what} at column {tok.column}, found {found}", column=tok.column
            )
        self.i += 1
        return tok

    def goal(self) -> Goal:
        literals = [self.literal()]
        while self.tok.kind != "end":
            if self.tok.text.lower() in ("and", ",", "&", "&&"):
                self.i += 1
                literals.append(self.literal())
            else:
                tok = self.tok
                raise GoalParseError(
                    f"expected 'and' or ',' between facts at column {tok.column}, found "
                    f"{tok.text!r}",
                    column=tok.column,
                )
        return Goal(literals=tuple(literals))

    def literal(self) -> GoalLiteral:
        holds = True
        while self.tok.text.lower() in ("not", "!"):
            holds, self.i = not holds, self.i + 1
        head = self.tok
        if head.kind != "name":
            raise GoalParseError(
                f"expected a relation or property name at column {head.column}", column=head.column
            )
        self.i += 1
        kind = self.check.kind(head.text, head.column)
        self.expect("(", f"'(' after {head.text!r}")
        args = [self.argument()]
        while self.tok.text == ",":
            self.i += 1
            args.append(self.argument())
        self.expect(")", "')' or ','")
        value: Scalar = True
        if self.tok.text in ("=", "==", "!="):
            negate = self.tok.text == "!="
            self.i += 1
            value = self.value()
            holds = holds != negate
        want = 2 if kind == "relation" else 1
        if len(args) != want:
            shape = "(subject, object)" if want == 2 else "(element)"
            raise GoalParseError(
                f"{head.text!r} is a {kind} and takes {want} argument{'s' * (want > 1)} "
                f"{shape}, got {len(args)} at column {head.column}",
                column=head.column,
            )
        if kind == "relation":
            if not isinstance(value, bool):
                raise GoalParseError(
                    f"a relation is true or false; '{head.text}(...) = {value}' makes no sense",
                    column=head.column,
                )
            lit = RelationGoal(
                predicate=head.text, subject=args[0], object=args[1], holds=holds == value
            )
            return self.check.relation(lit, head.column)
        prop = PropertyGoal(element=args[0], property=head.text, value=value, holds=holds)
        return self.check.property(prop, head.column)

    def argument(self) -> str:
        tok = self.tok
        if tok.kind == "string":
            self.i += 1
            return self.check.element(tok.text[1:-1], tok.column)
        if tok.kind in ("name", "number"):
            self.i += 1
            return self.check.element(tok.text, tok.column)
        raise GoalParseError(
            f"expected an element id or a quoted label at column {tok.column}", column=tok.column
        )

    def value(self) -> Scalar:
        tok = self.tok
        self.i += 1
        if tok.kind == "string":
            return tok.text[1:-1]
        if tok.kind == "number":
            if re.fullmatch(r"-?\d+", tok.text):
                return int(tok.text)
            raise GoalParseError(
                f"numeric goals such as {tok.text} are not supported (skills predict no "
                "numbers); use a boolean, integer or text value",
                column=tok.column,
            )
        if tok.kind == "name":
            lowered = tok.text.lower()
            return True if lowered == "true" else False if lowered == "false" else tok.text
        raise GoalParseError(f"expected a value at column {tok.column}", column=tok.column)


def parse_goal(text: str, view: WorldView) -> Goal:
    """Parse goal text (see the module doc) against ``view``; labels become ids."""
    if not text.strip():
        raise GoalParseError(
            "the goal is empty: give at least one fact, e.g. contain(Box-1, Gear-2)"
        )
    return _Parser(text, view).goal()
