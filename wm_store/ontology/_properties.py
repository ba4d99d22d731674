"""Reading property declarations: object properties (:func:`read_relations`: super-properties,
spatial inheritance, domains and ranges) and data properties (:func:`read_data_property`: the
``rdfs:range`` datatype, restriction facets or union, ``skm:valueKind``, ``skm:tolerance`` and
``skm:resolution``), each checked against the others for consistency.

Part of :func:`wm_store.ontology._model.compile_graph`; errors are OntologyError naming the
property and the fix.
"""

from __future__ import annotations

import math
from typing import Final

from rdflib import OWL, RDFS, XSD, URIRef
from rdflib.collection import Collection
from rdflib.term import Node

from wm_store._errors import OntologyError
from wm_store.ontology._literals import DATATYPE_KINDS, SKM
from wm_store.ontology._reader import GraphReader, read_number
from wm_store.ontology._terms import (
    ALL_KINDS,
    FUSABLE_KINDS,
    KIND_ALIASES,
    RESOLUTIONS,
    DataPropertyInfo,
    RelationInfo,
    local_name,
)

__all__ = ["read_data_property", "read_relations"]

_IMPLIED_MINIMUM: Final = {XSD.nonNegativeInteger: 0.0, XSD.positiveInteger: 1.0}


def _closure(parents: dict[str, list[str]], name: str) -> set[str]:
    seen: set[str] = set()
    todo = list(parents.get(name, ()))
    while todo:
        p = todo.pop()
        if p == name:
            raise OntologyError(f"'{name}' is its own super-property; break the cycle")
        if p not in seen:
            seen.add(p)
            todo.extend(parents.get(p, ()))
    return seen


def read_relations(r: GraphReader) -> dict[str, RelationInfo]:
    """Every declared object property; ``spatial`` is inherited from super-properties."""
    parents = {
        name: r.superproperties(iri, r.relations, f"relation '{name}'")
        for iri, name in r.relations.items()
    }
    spatial_root = local_name(SKM.spatialRelation)
    marked = {name for iri, name in r.relations.items() if r.flag(iri, SKM.spatial)}
    out: dict[str, RelationInfo] = {}
    for iri, name in r.relations.items():
        ancestors = _closure(parents, name) | {name}
        spatial = spatial_root in ancestors or bool(ancestors & marked)
        if r.flag(iri, SKM.spatial) is False and spatial:
            raise OntologyError(
                f"relation '{name}' is annotated skm:spatial false but is a sub-property of a "
                "spatial relation; remove the annotation or the rdfs:subPropertyOf"
            )
        domains = r.class_set(iri, RDFS.domain, f"relation '{name}'")
        ranges = r.class_set(iri, RDFS.range, f"relation '{name}'")
        out[name] = RelationInfo(
            name=name,
            domain=next(iter(domains)) if len(domains) == 1 else None,
            range=next(iter(ranges)) if len(ranges) == 1 else None,
            spatial=spatial,
            parents=tuple(parents[name]),
            label=r.text(iri, RDFS.label),
            comment=r.text(iri, RDFS.comment),
            domains=domains,
            ranges=ranges,
            abstract=bool(r.flag(iri, SKM.abstract)),
        )
    return out


def _read_range(
    r: GraphReader, node: Node, where: str
) -> tuple[frozenset[str], float | None, float | None]:
    """Kinds, minimum and maximum of an rdfs:range (datatype, restriction or union)."""
    if isinstance(node, URIRef):
        if node not in DATATYPE_KINDS:
            raise OntologyError(
                f"{where}: unsupported range {node}; use xsd:double/integer/boolean/string, "
                "a skm typed-value datatype, skm:json or rdfs:Literal"
            )
        return DATATYPE_KINDS[node], _IMPLIED_MINIMUM.get(node), None
    union = r.g.value(node, OWL.unionOf)
    if union is not None:
        kinds = frozenset().union(*(_read_range(r, m, where)[0] for m in Collection(r.g, union)))
        return kinds, None, None
    base = r.g.value(node, OWL.onDatatype)
    if base is None:
        raise OntologyError(f"{where}: a range must be a datatype, a restriction or a union")
    kinds, minimum, maximum = _read_range(r, base, where)
    facets = r.g.value(node, OWL.withRestrictions)
    for facet in Collection(r.g, facets) if facets is not None else ():
        for p, o in r.g.predicate_objects(facet):
            if p == XSD.minInclusive:
                minimum = read_number(o, where)
            elif p == XSD.maxInclusive:
                maximum = read_number(o, where)
            else:
                raise OntologyError(
                    f"{where}: facet {local_name(str(p))} is not supported; use minInclusive / "
                    "maxInclusive (with skm:tolerance for measurement noise)"
                )
    return kinds, minimum, maximum


def read_data_property(r: GraphReader, iri: URIRef, name: str) -> DataPropertyInfo:
    """The data property ``name`` (at ``iri``), its range, kinds, tolerance and resolution."""
    where = f"data property '{name}'"
    ranges = list(r.g.objects(iri, RDFS.range))
    if len(ranges) > 1:
        raise OntologyError(f"{where} has {len(ranges)} rdfs:range statements; state one")
    range_kinds, minimum, maximum = (
        _read_range(r, ranges[0], where) if ranges else (ALL_KINDS, None, None)
    )
    kinds = range_kinds
    declared = [str(o) for o in r.g.objects(iri, SKM.valueKind)]
    if declared:
        unknown = [k for k in declared if k not in ALL_KINDS and k not in KIND_ALIASES]
        if unknown:
            raise OntologyError(
                f"{where}: unknown skm:valueKind {unknown}; use one of "
                f"{sorted(ALL_KINDS | KIND_ALIASES.keys())}"
            )
        kinds = frozenset().union(*(KIND_ALIASES.get(k, frozenset({k})) for k in declared))
        widened = range_kinds | ({"float"} if "int" in range_kinds else set())
        if not kinds <= widened and range_kinds != frozenset({"list"}):
            raise OntologyError(
                f"{where}: skm:valueKind {sorted(kinds)} does not fit its rdfs:range "
                f"({sorted(range_kinds)}); make them agree"
            )
    numeric = bool(kinds & {"float", "int"})
    if (minimum is not None or maximum is not None) and not numeric:
        raise OntologyError(f"{where}: a numeric range needs a numeric kind, not {sorted(kinds)}")
    if minimum is not None and maximum is not None and minimum > maximum:
        raise OntologyError(f"{where}: minimum {minimum} is above maximum {maximum}")
    tol_node = r.g.value(iri, SKM.tolerance)
    tolerance = read_number(tol_node, where) if tol_node is not None else 0.0
    if tolerance < 0 or not math.isfinite(tolerance):
        raise OntologyError(f"{where}: skm:tolerance must be a finite number >= 0")
    resolution = str(r.g.value(iri, SKM.resolution) or "latest")
    if resolution not in RESOLUTIONS:
        raise OntologyError(f"{where}: skm:resolution {resolution!r} is not one of {RESOLUTIONS}")
    if resolution == "fused" and not (kinds - {"list"}) <= FUSABLE_KINDS:
        raise OntologyError(
            f"{where}: 'fused' needs numbers or positions, not {sorted(kinds)}; "
            "use 'most_confident'"
        )
    domains = r.class_set(iri, RDFS.domain, where)
    return DataPropertyInfo(
        name=name,
        kinds=kinds,
        minimum=minimum,
        maximum=maximum,
        tolerance=tolerance,
        resolution=resolution,  # type: ignore[arg-type]
        domain=next(iter(domains)) if len(domains) == 1 else None,
        label=r.text(iri, RDFS.label),
        comment=r.text(iri, RDFS.comment),
        domains=domains,
    )
