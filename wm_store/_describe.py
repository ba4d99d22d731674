"""World-model changes in words, for people: :func:`describe_change` (one line per committed
transaction), used by ``skimesh wm watch`` / ``wm history`` and the mission recording."""

from __future__ import annotations

from collections.abc import Callable

from wm_store.protocol import (
    Change,
    ClassDefined,
    ElementPut,
    ElementRemoved,
    RelationAdded,
    RelationRemoved,
    TemplateDefined,
    TermsDefined,
)

__all__ = ["describe_change"]

_MAX_ITEMS = 6
"""More deltas than this in one change are counted, not listed."""


def describe_change(change: Change, name_of: Callable[[str], str] = str) -> str:
    """One line for a committed transaction: revision, author and what it did (each delta
    when there are a few, else counts). ``name_of`` names an element by id (e.g. its display
    name)."""
    items: list[str] = []
    counts = {"put": 0, "removed": 0, "+rel": 0, "-rel": 0, "defined": 0}
    for delta in change.deltas:
        match delta:
            case ElementPut(element=e):
                counts["put"] += 1
                items.append(f"put {e.label or e.id}")
            case ElementRemoved(id=eid):
                counts["removed"] += 1
                items.append(f"removed {eid}")
            case RelationAdded(relation=r) | RelationRemoved(relation=r):
                sign = "+" if isinstance(delta, RelationAdded) else "-"
                counts[f"{sign}rel"] += 1
                items.append(f"{sign}{r.predicate}({name_of(r.subject)}, {name_of(r.object)})")
            case ClassDefined(cls=c):
                counts["defined"] += 1
                items.append(f"class {c.name}")
            case TemplateDefined(template=t):
                counts["defined"] += 1
                items.append(f"template {t.name}")
            case TermsDefined(terms=terms):
                counts["defined"] += 1
                items.append(f"terms from {terms.source or 'a text'}")
    items = list(dict.fromkeys(items))  # an element updated twice in one transaction: once
    head = f"rev {change.revision} by {change.author or '?'}:"
    if len(items) <= _MAX_ITEMS:
        return f"{head} {', '.join(items) or 'no change'}"
    what = ", ".join(f"{n} {k}" for k, n in counts.items() if n)
    return f"{head} {len(change.deltas)} deltas ({what})"
