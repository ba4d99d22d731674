"""A scenario's initial scene in the world model, loaded once.

:func:`scene_ops` is what ``skimesh wm --scenario S`` (the store, at its start),
``skimesh wm import-scenario S`` (a client of a running store) and ``skimesh demo`` write: the
scenario's own ontology terms (:func:`scenario_terms`, its ``ontology`` files), then the ops of
:func:`scenario.wm.scenario_ops`, in one transaction.

- **Once**: a world model that already holds any of the scenario's furniture or parts has its
  scene (a durable store restarted with ``--scenario``, an import repeated): nothing to write.
- **Robots registered first are reused**: an agent started before the scene registers its
  robot and devices, then fails to wire a fixed camera; those elements are reused by label
  (updated, not added twice), so the agents wire cleanly once the scene is there. A scenario
  label that is already the id of such an element is a :class:`~scenario.ScenarioError`
  (:mod:`scenario.wm._names`).

:func:`read_scenario` finds a scenario by name (``configs/scenarios/NAME/scenario.toml``) or
file; an unknown name is a :class:`~device_drivers.ScenarioError` naming the known ones.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from scenario._errors import ScenarioError
from scenario._schema import Scenario
from scenario.wm._names import name_clashes
from scenario.wm._ops import scenario_ops
from wm_store import WmError
from wm_store.ontology import Ontology
from wm_store.protocol import AddElement, DefineTerms, Op, TermsDef
from wm_store.scene import SceneState

__all__ = ["scenario_terms", "scene_loaded", "scene_ops"]

_NOT_SCENE = ("Agent", "Skill")
"""Classes of what agents register beside their robot: never a scenario's element."""


def scene_loaded(scenario: Scenario, state: SceneState) -> list[str]:
    """The scenario's furniture and parts already in ``state`` (empty: its scene is not)."""
    labels = [f.label for f in scenario.furniture] + [p.label for p in scenario.parts]
    return [label for label in labels if state.ids_with_label(label)]


def scenario_terms(scenario: Scenario) -> list[DefineTerms]:
    """The scenario's ontology terms (its ``ontology`` files), one op per file. Reads files:
    call it off the event loop. Raises ScenarioError naming a missing or unreadable file."""
    ops = []
    for name in scenario.ontology:
        path = Path(name)
        try:
            text = path.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as exc:
            raise ScenarioError(
                f"scenario {scenario.name!r}: cannot read its ontology file {name}: {exc}"
            ) from exc
        ops.append(DefineTerms(terms=TermsDef(turtle=text, source=path.name)))
    return ops


def scene_ops(
    scenario: Scenario,
    state: SceneState,
    ontology: Ontology,
    *,
    terms: Sequence[DefineTerms] | None = None,
) -> list[Op]:
    """The ops that load ``scenario``'s scene into a world model holding ``state`` (see the
    module doc): first the scenario's ontology terms (``terms``, default
    :func:`scenario_terms`), then its elements; only the terms when the scene is there already
    (teaching known terms changes nothing). Refs are ``$<label>``."""
    terms = scenario_terms(scenario) if terms is None else terms
    if scene_loaded(scenario, state):
        return list(terms)
    for op in terms:
        try:
            ontology = ontology.teach(op.terms.turtle, source=op.terms.source)
        except WmError as exc:
            raise ScenarioError(f"scenario {scenario.name!r}: {exc}") from exc
    return [*terms, *_element_ops(scenario, state, ontology)]


def _element_ops(scenario: Scenario, state: SceneState, ontology: Ontology) -> list[Op]:
    labels = [op.label for op in scenario_ops(scenario, ontology=ontology)
              if isinstance(op, AddElement)]  # fmt: skip
    existing: dict[str, str] = {}
    for label in labels:
        ids = [i for i in state.ids_with_label(label) if not _registered(state, ontology, i)]
        if len(ids) == 1:
            existing[label] = ids[0]
    ops = scenario_ops(scenario, existing, ontology=ontology)
    clashes = name_clashes(ops, state)
    if clashes:
        raise ScenarioError("; ".join(clashes), source=scenario.source or scenario.name)
    return ops


def _registered(state: SceneState, ontology: Ontology, element: str) -> bool:
    cls = state.elements[element].type
    known = ontology.classes
    return cls in known and any(c in known and ontology.is_a(cls, c) for c in _NOT_SCENE)
