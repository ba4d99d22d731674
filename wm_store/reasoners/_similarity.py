"""Classify and identify by property similarity (SkiROS, Appendix B).

``classify``: which templates (default individuals) or classes does an observed element most
resemble? ``identify``: which element already in the scene is the observed one?

Similarity formula
------------------
Two elements are compared on every property both of them have (in ``ignore`` excepted), each
giving a similarity ``s_p`` in [0, 1]:

- numbers (mass, volume…): ``1 - |a - b| / max(|a|, |b|)`` (relative difference; 1 if both 0);
- sizes (``SizeCuboid`` / ``SizeCylinder`` / ``SizeSphere``): each becomes the edge lengths of
  its bounding box, sorted (so a box seen lying on another face still matches); then
  ``1 - Σ|a_i - b_i| / Σ max(a_i, b_i)``, halved when the shapes are of different kinds;
- ``Color``: ``1 - ‖rgb_a - rgb_b‖ / √3`` (alpha ignored);
- strings and booleans: 1 if equal, else 0; values of different kinds: 0;
- positions (``identify`` only, ``position_scale`` metres): world positions are computed by the
  :class:`~wm_store.reasoners.SpatialReasoner` and give ``max(0, 1 - d / scale)``;
  skipped when either has no resolvable pose. ``classify`` never compares positions: where
  a thing is says nothing about what it is.
- lists, ``Frame`` and ``Orientation`` values are not compared.

The score is the weighted mean ``Σ w_p s_p / Σ w_p`` (weights default to 1) over the compared
properties; with no property in common it is 0. Results are those with ``score >= threshold``,
best first, ties in natural name order (``Cup-2`` before ``Cup-10``): the same input always
gives the same list.

Everything here is pure and quick (linear in the candidates); nothing blocks.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from typing import TYPE_CHECKING, Literal

from wm_store._errors import ElementNotFoundError, PropertyValueError, ValidationError
from wm_store.protocol import (
    Color,
    Element,
    SizeCuboid,
    SizeCylinder,
    SizeSphere,
    TemplateDef,
    Value,
)
from wm_store.reasoners._spatial import SpatialReasoner
from wm_store.scene import SceneState, id_sort_key

if TYPE_CHECKING:
    from wm_store.ontology import Ontology

__all__ = ["SimilarityReasoner", "classify", "identify", "property_similarity", "similarity"]

_POSITIONAL = frozenset({"pose", "position", "orientation"})


def _extent(value: Value) -> tuple[str, list[float]] | None:
    match value:
        case SizeCuboid(x=x, y=y, z=z):
            return "cuboid", sorted((x, y, z))
        case SizeCylinder(radius=r, height=h):
            return "cylinder", sorted((2 * r, 2 * r, h))
        case SizeSphere(radius=r):
            return "sphere", [2 * r] * 3
    return None


def property_similarity(a: Value, b: Value) -> float | None:
    """Similarity in [0, 1] of two property values, or ``None`` if they are not compared
    (lists, frames, orientations, positions). See the module docstring for the formulas."""
    if isinstance(a, list) or isinstance(b, list) or a is None or b is None:
        return None
    if isinstance(a, bool) or isinstance(b, bool) or isinstance(a, str) or isinstance(b, str):
        return 1.0 if type(a) is type(b) and a == b else 0.0
    if isinstance(a, int | float) and isinstance(b, int | float):
        scale = max(abs(a), abs(b))
        return 1.0 if scale == 0 else max(0.0, 1.0 - abs(a - b) / scale)
    if isinstance(a, Color) and isinstance(b, Color):
        d = math.dist((a.r, a.g, a.b), (b.r, b.g, b.b))
        return max(0.0, 1.0 - d / math.sqrt(3.0))
    ea, eb = _extent(a), _extent(b)
    if ea is not None and eb is not None:
        total = sum(max(x, y) for x, y in zip(ea[1], eb[1], strict=True))
        s = (
            1.0
            if total == 0
            else 1.0 - sum(abs(x - y) for x, y in zip(ea[1], eb[1], strict=True)) / total
        )
        return s if ea[0] == eb[0] else s / 2
    if (
        _extent(a) is not None
        or _extent(b) is not None
        or isinstance(a, Color)
        or isinstance(b, Color)
    ):
        return 0.0  # a size or colour against something else
    return None


def similarity(
    a: Mapping[str, Value],
    b: Mapping[str, Value],
    *,
    weights: Mapping[str, float] | None = None,
    ignore: Iterable[str] = _POSITIONAL,
) -> tuple[float, float]:
    """Weighted mean similarity of two property maps and the total weight compared (0 when
    nothing was comparable)."""
    skip = frozenset(ignore)
    total = weighted = 0.0
    for name in sorted(a.keys() & b.keys() - skip):
        s = property_similarity(a[name], b[name])
        if s is None:
            continue
        w = 1.0 if weights is None else weights.get(name, 1.0)
        total += w
        weighted += w * s
    return (weighted / total if total else 0.0), total


def _check_threshold(threshold: float) -> None:
    if not 0.0 <= threshold <= 1.0:
        raise ValidationError(f"threshold must lie in [0, 1], not {threshold}")


def _ranked(scores: Iterable[tuple[str, float]], threshold: float) -> list[tuple[str, float]]:
    kept = [(name, score) for name, score in scores if score >= threshold]
    kept.sort(key=lambda item: (-round(item[1], 12), id_sort_key(item[0])))
    return kept


def _templates(state: SceneState, ontology: Ontology) -> dict[str, TemplateDef]:
    found = dict(ontology.templates)
    found.update(state.templates)
    return found


def classify(
    state: SceneState,
    ontology: Ontology,
    element: Element,
    candidates_type: str,
    threshold: float,
    *,
    by: Literal["template", "class"] = "template",
    weights: Mapping[str, float] | None = None,
) -> list[tuple[str, float]]:
    """Templates (``by="template"``) or classes (``by="class"``: each scored by its best
    template) of type ``candidates_type`` or a subclass that ``element`` resembles, with scores
    ``>= threshold``, best first. Templates come from the ontology and the view (those taught at
    run time). Raises ``UnknownClassError`` for an unknown ``candidates_type`` and
    ``ValidationError`` for a threshold outside [0, 1]."""
    _check_threshold(threshold)
    allowed = set(ontology.subclasses(ontology.check_class(candidates_type)))
    best: dict[str, float] = {}
    for template in _templates(state, ontology).values():
        if template.type not in allowed:
            continue
        score, _ = similarity(element.properties, template.properties, weights=weights)
        key = template.name if by == "template" else template.type
        best[key] = max(score, best.get(key, 0.0))
    return _ranked(best.items(), threshold)


def identify(
    state: SceneState,
    ontology: Ontology,
    observed: Element,
    threshold: float,
    *,
    position_scale: float | None = 0.5,
    weights: Mapping[str, float] | None = None,
) -> list[tuple[str, float]]:
    """Ids of the elements in ``state`` that ``observed`` may be, with scores ``>= threshold``,
    best first. Candidates have a compatible type (``observed.type`` or a subclass or ancestor
    of it); an element with ``observed.id`` is not its own candidate. ``position_scale``
    (metres) adds position similarity; ``None`` leaves positions out. Raises
    ``UnknownClassError`` for an unknown type, ``ValidationError`` for a bad threshold."""
    _check_threshold(threshold)
    cls = ontology.check_class(observed.type)
    types = set(ontology.subclasses(cls))
    types.update(ontology.superclasses(cls))
    spatial = SpatialReasoner(state, ontology)
    here = _world_position(spatial, observed) if position_scale else None
    scores: list[tuple[str, float]] = []
    for element_id in state.ids_of_types(types):
        if element_id == observed.id:
            continue
        candidate = state.elements[element_id]
        score, total = similarity(observed.properties, candidate.properties, weights=weights)
        if here is not None and position_scale:
            there = _world_position(spatial, candidate)
            if there is not None:
                w = 1.0 if weights is None else weights.get("position", 1.0)
                s = max(0.0, 1.0 - math.dist(here, there) / position_scale)
                score = (score * total + w * s) / (total + w)
        scores.append((element_id, score))
    return _ranked(scores, threshold)


def _world_position(
    spatial: SpatialReasoner, element: Element
) -> tuple[float, float, float] | None:
    try:
        return spatial.world_transform(element).translation
    except (PropertyValueError, ElementNotFoundError):
        return None


class SimilarityReasoner:
    """:func:`classify` and :func:`identify` bound to a view, as a :class:`Reasoner`."""

    name = "similarity"
    data_codes: frozenset[str] = frozenset()
    relations_computed: frozenset[str] = frozenset()
    properties_handled = frozenset({"size", "color", "mass", "pose", "position"})

    def __init__(self, view: SceneState, ontology: Ontology) -> None:
        self.view = view
        self.ontology = ontology

    def classify(
        self, element: Element, candidates_type: str, threshold: float = 0.0
    ) -> list[tuple[str, float]]:
        return classify(self.view, self.ontology, element, candidates_type, threshold)

    def identify(self, observed: Element, threshold: float = 0.0) -> list[tuple[str, float]]:
        return identify(self.view, self.ontology, observed, threshold)

    def get_data(self, element_id: str, code: str) -> Value:
        raise ValidationError(f"the similarity reasoner derives no data (asked for {code!r})")

    def compute_relations(self, subject: str, obj: str) -> frozenset[str]:
        return frozenset()
