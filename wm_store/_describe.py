"""World-model changes in words, for people: one line per committed transaction, used by
``skimesh wm watch`` / ``wm history``, the mission recording and the site event log.

Every :class:`~wm_store.protocol.ElementPut` carries the whole element, so what an update
changed is only known against the element before it. :class:`ChangeWords` remembers the last
element of each id it has seen (seeded from a replica's elements, or learnt change by change)
and words each change against that::

    rev 7 by cli: +Gear-9 [Gear] at (0.400, 0.100, 0.750); +contain(bin-a (Box-1), Gear-9)
    rev 8 by r1: Gear-1 pose (1.078, -1.250, 0.720) -> (0.445, -0.998, 0.370), seen by r1-camera
    rev 9 by cli: gear-y (Gear-2) label "gear-z" -> "gear-y", mass 0.12 -> 0.2; removed Bolt-3

``+X [Type]`` is an element the change added; ``put X [Type]`` one this reader had not seen
(without the state before the change, or after a gap in the revisions it was given, it cannot
tell an addition from an update); an update names the properties it changed, with old -> new
for the first few; ``seen`` stands for new observations and a new ``seenAt``.
:func:`describe_change` words one change with no prior knowledge.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable

from wm_store.ontology import Prop
from wm_store.protocol import (
    Change,
    ClassDefined,
    Element,
    ElementPut,
    ElementRemoved,
    Observation,
    Pose,
    Position,
    RelationAdded,
    RelationRemoved,
    TemplateDefined,
    TermsDefined,
)
from wm_store.scene._names import display_name

from ._describe_values import value_text

__all__ = ["ChangeWords", "describe_change"]

_MAX_ITEMS = 6
"""More items than this in one change are counted, not listed."""
_MAX_VALUES = 3
"""An update shows old -> new for this many properties; the others by name."""
_MAX_PARTS = 6
"""An update names this many changes of an element; the others are counted."""
_LONG_VALUE = 64
"""A value longer than this is not shown (the property is named)."""

NameOf = Callable[[str], str]


class ChangeWords:
    """Words changes against what was known before each (see the module doc).

    ``elements``: every element of the world model at ``revision`` (e.g. a replica's, taken
    when its change stream is subscribed), so an element not among them is new; None: nothing
    is known yet (learnt from the changes worded; a change of revision 1 starts from the empty
    store). Memory: the last element of each id (no history).
    """

    def __init__(self, elements: Iterable[Element] | None = None, *, revision: int = 0) -> None:
        self._known: dict[str, Element] = {}
        self.complete = False
        """Whether every element is known (an unknown one is then new)."""
        self.revision = 0
        if elements is not None:
            self.seed(elements, revision)

    def seed(self, elements: Iterable[Element], revision: int = 0) -> None:
        """Know exactly ``elements``: the world model at ``revision`` (0: not said)."""
        self._known = {e.id: e for e in elements}
        self.complete, self.revision = True, revision

    def name(self, element_id: str, name_of: NameOf | None = None) -> str:
        """How to name an element: by what is known of it, else by ``name_of`` (else its id)."""
        known = self._known.get(element_id)
        if known is not None or name_of is None:
            return display_name(known, element_id)
        return name_of(element_id)

    def __call__(self, change: Change, name_of: NameOf | None = None) -> str:
        """One line for ``change`` (revision, author, what it did: each item when there are a
        few, else counts), learning it. ``name_of`` names elements this reader does not know
        (e.g. the replica's display names); changes must come in revision order."""
        if change.revision == 1 and not self._known:
            self.complete = True  # the store starts empty
        elif self.revision and change.revision != self.revision + 1:
            self.complete = False  # changes were missed: an unknown element may be old
        self.revision = change.revision
        items, counts = _Items(self, name_of, change).word(change)
        head = f"rev {change.revision} by {change.author or '?'}:"
        if len(items) <= _MAX_ITEMS:
            return f"{head} {'; '.join(items) or 'no change'}"
        what = ", ".join(f"{n} {k}" for k, n in counts.items() if n)
        return f"{head} {len(change.deltas)} deltas ({what})"


def describe_change(change: Change, name_of: NameOf | None = None) -> str:
    """One line for ``change``, with no knowledge of the world model before it (an element put
    reads ``put X [Type]``, or ``+X [Type]`` where the change names it as added); ``name_of``
    names the elements the change does not carry (e.g. by their display names). To word what an
    update changed, use :class:`ChangeWords`."""
    return ChangeWords()(change, name_of)


class _Items:
    """The items of one change, learnt into ``words`` as they are worded."""

    def __init__(self, words: ChangeWords, name_of: NameOf | None, change: Change) -> None:
        self.words, self.name_of = words, name_of
        self.added = set(change.ids.values())
        self.gone: dict[str, Element] = {}
        """Elements this change removed: named as they were."""
        self.counts = dict.fromkeys(
            ("new", "put", "updated", "unchanged", "removed", "+rel", "-rel", "defined"), 0
        )

    def _name(self, element_id: str) -> str:
        gone = self.gone.get(element_id)
        return display_name(gone) if gone else self.words.name(element_id, self.name_of)

    def word(self, change: Change) -> tuple[list[str], dict[str, int]]:
        """The items (an element put several times worded once, against its state before
        the change; an unchanged put left out where other items exist) and the counts."""
        known = self.words._known
        before: dict[str, Element | None] = {}  # the elements this change touches, before it
        slots: list[tuple[str, str]] = []  # ("", text) or ("element", its id)
        for delta in change.deltas:
            match delta:
                case ElementPut(element=e):
                    slots += self._touch(before, e.id)
                    known[e.id] = e
                case ElementRemoved(id=eid):
                    slots += self._touch(before, eid)
                    gone = known.pop(eid, None)
                    if gone is not None:
                        self.gone[eid] = gone
                case RelationAdded(relation=r) | RelationRemoved(relation=r):
                    sign = "+" if isinstance(delta, RelationAdded) else "-"
                    self.counts[f"{sign}rel"] += 1
                    what = f"{r.predicate}({self._name(r.subject)}, {self._name(r.object)})"
                    slots.append(("", sign + what))
                case ClassDefined(cls=c):
                    slots.append(("", f"class {c.name}"))
                case TemplateDefined(template=t):
                    slots.append(("", f"template {t.name}"))
                case TermsDefined(terms=terms):
                    slots.append(("", f"terms from {terms.source or 'a text'}"))
            if isinstance(delta, ClassDefined | TemplateDefined | TermsDefined):
                self.counts["defined"] += 1
        worded: list[str] = []
        unchanged: list[str] = []
        for kind, text in slots:
            if kind:
                text, kind = self._element(before[text], known.get(text), text)
                if not kind:
                    continue
                self.counts[kind] += 1
            (unchanged if kind == "unchanged" else worded).append(text)
        return list(dict.fromkeys(worded or unchanged)), self.counts

    def _touch(self, before: dict[str, Element | None], element_id: str) -> list[tuple[str, str]]:
        """The element's slot, the first time the change touches it (and its state then)."""
        if element_id in before:
            return []
        before[element_id] = self.words._known.get(element_id)
        return [("element", element_id)]

    def _element(self, old: Element | None, new: Element | None, eid: str) -> tuple[str, str]:
        """An element's item and its kind ("" when there is nothing to say)."""
        if new is None:
            if old is None and eid in self.gone:
                return "", ""  # added and removed by this one change
            return f"removed {self._name(eid)}", "removed"
        shown = f"{display_name(new)} [{new.type}]"
        if old is None:
            new_one = eid in self.added or self.words.complete
            at = _where(new.properties.get(Prop.pose), self._name)
            return (f"+{shown}{at}", "new") if new_one else (f"put {shown}", "put")
        parts = _differences(old, new, self._name)
        if not parts:
            return f"{display_name(new)} unchanged", "unchanged"
        return f"{display_name(new)} {', '.join(parts)}", "updated"


def _where(pose: object, name_of: NameOf) -> str:
    """`` at (x, y, z)`` for a pose or a position, else nothing."""
    return f" at {value_text(pose, name_of)}" if isinstance(pose, Pose | Position) else ""


def _differences(old: Element, new: Element, name_of: NameOf) -> list[str]:
    """What changed from ``old`` to ``new``: the class, the label, each property (old -> new
    for the first few, by name after them), ``seen`` for observations and ``seenAt``."""
    parts: list[str] = []
    if old.type != new.type:
        parts.append(f"class {old.type} -> {new.type}")
    if old.label != new.label:
        parts.append(f"label {value_text(old.label)} -> {value_text(new.label)}")
    shown = 0
    for key in [*new.properties, *(k for k in old.properties if k not in new.properties)]:
        if key == Prop.seenAt:
            continue
        before, after = old.properties.get(key), new.properties.get(key)
        if before == after:
            continue
        was, now = value_text(before, name_of), value_text(after, name_of)
        if shown < _MAX_VALUES and was != now and max(len(was), len(now)) <= _LONG_VALUE:
            parts.append(f"{key} {was} -> {now}")
            shown += 1
        else:
            parts.append(key)
    seen = _seen(old, new, name_of)
    if seen:
        parts.append(seen)
    if len(parts) > _MAX_PARTS:
        parts[_MAX_PARTS - 1 :] = [f"{len(parts) - _MAX_PARTS + 1} more"]
    return parts


def _seen(old: Element, new: Element, name_of: NameOf) -> str:
    """``seen`` (``seen by S``, naming the sources of new observations) when the element's
    observations or ``seenAt`` changed, else ``""``."""
    if old.observations == new.observations:
        return "seen" if old.properties.get(Prop.seenAt) != new.properties.get(Prop.seenAt) else ""
    sources: dict[str, None] = {}
    for prop, observations in new.observations.items():
        previous: list[Observation] = old.observations.get(prop, [])
        for observation in observations:
            if observation not in previous:
                sources[observation.source] = None
    return f"seen by {', '.join(name_of(s) for s in sources)}" if sources else "seen"
