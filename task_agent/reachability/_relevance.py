"""Problem compression: the objects a goal can touch, found without a planner.

:func:`relevant_objects` closes backwards from the goal over the actions' effects and
preconditions, lifted (unbound parameters are wildcards, variables unify only with objects of
their types: :class:`Typing`); the planner hands the engine only the objects it keeps.
:class:`Writers` (which effects make a fact hold, with a sign) and :func:`unify` serve
:func:`~task_agent.reachability.diagnose` too. Pure.
"""

from __future__ import annotations

from collections import defaultdict, deque
from collections.abc import Mapping

from ..domain import ROOT_TYPE, ActionSchema, ForallDelete, PlanningTask
from ._replay import State

__all__ = ["Signed", "Typing", "Writers", "relevant_objects", "unify"]

_FREE = "\x00w"  # the quantified variable of a conditional delete
Signed = tuple[str, tuple[str | None, ...], bool]
"""A pattern (a fact with wildcards, None) and the sign it is needed with."""
_Writer = tuple[ActionSchema, tuple[str, ...], ForallDelete | None]


class Writers:
    """The actions' effects that make facts hold with a sign, found by (predicate, sign) and
    by the effect's first argument when it is an element id (most are: agents' hardware)."""

    def __init__(self, task: PlanningTask) -> None:
        self._any: dict[tuple[str, bool], list[_Writer]] = defaultdict(list)
        self._first: dict[tuple[str, bool, str], list[_Writer]] = defaultdict(list)
        for schema in task.actions.values():
            for lit in schema.add:
                self._put(lit.pred, True, (schema, lit.args, None))
            for lit in schema.delete:
                self._put(lit.pred, False, (schema, lit.args, None))
            for fd in schema.forall_delete:
                args = (_FREE, fd.fixed) if fd.free_pos == 0 else (fd.fixed, _FREE)
                self._put(fd.delete, False, (schema, args, fd))

    def _put(self, pred: str, sign: bool, writer: _Writer) -> None:
        first = writer[1][0] if writer[1] else "?"
        if first[0] == "?" or first == _FREE:
            self._any[(pred, sign)].append(writer)
        else:
            self._first[(pred, sign, first)].append(writer)

    def get(self, pred: str, sign: bool, args: tuple[str | None, ...]) -> list[_Writer]:
        """Writers whose effect may unify with ``pred(args)``."""
        found = self._any.get((pred, sign), [])
        if args and args[0] is not None:
            return found + self._first.get((pred, sign, args[0]), [])
        mine = [w for (p, s, _), ws in self._first.items() if (p, s) == (pred, sign) for w in ws]
        return found + mine


class Typing:
    """Which objects fit which types, memoized; the variables' types per action."""

    def __init__(self, task: PlanningTask) -> None:
        self.task = task
        self.variables = {s.name: {f"?{n}": t for n, t in s.params} for s in task.actions.values()}
        self._fits: dict[tuple[str, str], bool] = {}

    def fits(self, obj: str, wanted: str) -> bool:
        key = (obj, wanted)
        found = self._fits.get(key)
        if found is None:
            t: str | None = self.task.objects.get(obj)
            found = wanted == ROOT_TYPE
            while t is not None and not found:
                found = t == wanted
                t = self.task.types.get(t)
            self._fits[key] = found
        return found


def unify(
    eff: tuple[str, ...],
    pattern: tuple[str | None, ...],
    schema: ActionSchema,
    typing: Typing,
) -> dict[str, str | None] | None:
    """Bind the effect's variables to the pattern's objects, of the variables' types; None
    if they do not match."""
    b: dict[str, str | None] = {}
    types = typing.variables[schema.name]
    for e, p in zip(eff, pattern, strict=True):
        if e == _FREE:
            b[e] = p
        elif e[0] == "?":
            prev = b.get(e)
            if p is None:
                b.setdefault(e, None)
            elif prev is None:
                if not typing.fits(p, types[e]):
                    return None
                b[e] = p
            elif prev != p:
                return None
        elif p is not None and e != p:
            return None
    return b


def _reads(
    schema: ActionSchema, task: PlanningTask, b: Mapping[str, str | None], fd: ForallDelete | None
) -> list[Signed]:
    """What the action needs, as signed patterns, when ``b`` binds some of its variables."""

    def sub(a: str) -> str | None:
        return b.get(a) if a.startswith("?") else a

    out: list[Signed] = [
        (lit.pred, tuple(sub(a) for a in lit.args), lit.positive)
        for lit in schema.pre
        if not task.predicates[lit.pred].static
    ]
    for preds, arg, positive in schema.empty_pre:
        out += [(p, (sub(arg), None), not positive) for p in preds]
    if fd is not None:
        x, w = sub(fd.fixed), b.get(_FREE)
        out.append((fd.cond, (w, x) if fd.free_pos == 0 else (x, w), True))
    return out


def _subsumed(pattern: Signed, seen: set[Signed]) -> bool:
    """``pattern`` or a pattern more general than it is in ``seen``."""
    pred, args, sign = pattern
    if len(args) == 2:
        a, c = args
        return any((pred, g, sign) in seen for g in ((a, c), (None, c), (a, None), (None, None)))
    for mask in range(1 << len(args)):
        general = tuple(None if mask >> i & 1 else a for i, a in enumerate(args))
        if (pred, general, sign) in seen:
            return True
    return False


def relevant_objects(task: PlanningTask) -> set[str]:
    """The objects the goal can touch (see the module doc).

    Backward from the goal, delete-relaxed: a needed positive fact (and a negative goal
    fact) makes the actions that achieve it relevant, and their preconditions needed in turn;
    a needed negative fact is not chased further, but the initial facts it matches keep their
    objects (a gripper's current content matters to an "empty gripper" precondition). Kept:
    every object named by a needed pattern or by an initial fact matching one, the goal's
    elements and the actions' constants."""
    writers = Writers(task)
    typing = Typing(task)
    seen: set[Signed] = set()
    todo: deque[Signed] = deque()
    expanded: set[tuple[str, tuple[tuple[str, str | None], ...], ForallDelete | None]] = set()

    def push(p: Signed, chase: bool) -> None:
        if not _subsumed(p, seen):
            seen.add(p)
            if chase:
                todo.append(p)

    for lit in task.goal:
        push((lit.pred, lit.args, lit.positive), True)
    while todo:
        pred, args, sign = todo.popleft()
        for schema, eff, fd in writers.get(pred, sign, args):
            b = unify(eff, args, schema, typing)
            if b is None:
                continue
            key = (schema.name, tuple(sorted(b.items(), key=lambda kv: kv[0])), fd)
            if key not in expanded:  # the same action instance, reached another way
                expanded.add(key)
                for p in _reads(schema, task, b, fd):
                    push(p, p[2])
    keep = {a for _, args, _ in seen for a in args if a is not None}
    init = State(task.init)
    for pred, args, _ in seen:
        bound = [(i, a) for i, a in enumerate(args) if a is not None]
        found = init.matching(pred, *bound[0]) if bound else init.facts
        for f in found:
            if f[0] == pred and all(f[1][i] == a for i, a in bound[1:]):
                keep.update(f[1])
    for schema in task.actions.values():
        keep |= set(schema.bound.values())
        keep |= {a for lit in schema.pre for a in lit.args if not a.startswith("?")}
    return keep & set(task.objects)
