"""What the verifier knows of one call on one agent (:class:`Attempt`) and of the steps before
it (:class:`Earlier`), shared by the call checks (``_call``, ``_values``, ``_dataflow``)."""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Literal

from skill_agent import WorldView
from skill_agent.protocol import SkillDescription
from wm_store.protocol import Value

from ..discovery import AgentInfo
from ..taskfile import BlockSite, CallSite

__all__ = ["REF_FORM", "Attempt", "Earlier", "Kind", "is_of", "listing"]

Kind = Literal["dataflow", "type", "resource", "precondition", "unknown", "structure"]
REF_FORM = "'@<step id>.<param>'"


def listing(items: Iterable[str], limit: int = 8) -> str:
    """``a, b, c and 4 more`` (``none`` when empty)."""
    shown = list(items)
    more = f" and {len(shown) - limit} more" if len(shown) > limit else ""
    return ", ".join(shown[:limit]) + more if shown else "none"


@dataclass
class Attempt:
    """One call on one agent: what was found, and the values it would run with."""

    agent: AgentInfo
    desc: SkillDescription
    problems: list[tuple[Kind, str]] = field(default_factory=list)
    warnings: list[tuple[Kind, str]] = field(default_factory=list)
    given: dict[str, Value] = field(default_factory=dict)
    """The values the call gives (labels and references resolved)."""
    values: dict[str, Value] | None = None
    """Every parameter as specified (None: the call cannot be specified)."""
    inferred: dict[str, str] = field(default_factory=dict)
    blocked: bool = False
    """A data-flow source has no prediction (its own problem is reported there)."""

    def fail(self, kind: Kind, message: str) -> None:
        self.problems.append((kind, message))


@dataclass(frozen=True)
class Earlier:
    """What the steps simulated so far left for data flow (all keyed by block path)."""

    ids: Mapping[str, Sequence[BlockSite]]
    """Block id -> the blocks with that id (several: a structure problem)."""
    calls: Mapping[str, CallSite]
    descs: Mapping[str, SkillDescription]
    """The description of each call whose agent and skill are known."""
    params: Mapping[str, Mapping[str, Value]]
    """The predicted values of each call that could be specified."""


def is_of(view: WorldView, element_id: str, cls: str) -> bool:
    element = view.find_element(element_id)
    return element is not None and view.ontology.is_a(element.type, cls)
