"""Goal text: :func:`parse_goal` reads ``contain(KitBox-1, Gear-3) and heating(Oven-1)`` (the
syntax is in :mod:`task_agent._goals`) into a checked :class:`~task_agent.Goal`; errors name
the column."""

from __future__ import annotations

import re

import msgspec

from skill_agent import WorldView

from ._errors import GoalParseError
from ._goals import Goal, GoalChecker, GoalLiteral, PropertyGoal, RelationGoal, Scalar

__all__ = ["parse_goal"]

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
        self.check = GoalChecker(view)

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
