"""The loaded ontology: class taxonomy, relations, typed data properties, cardinalities and
default individuals (templates), with the checks the store runs on every write.

    onto = Ontology.default()                      # ontologies/skimesh.ttl
    onto.is_a("KitBox", "Container")               # True: closures are precomputed
    onto.check_relation("Gripper", "contain", "Gear")
    onto.check_value("graspWidth", 0.204)          # within [0, 0.2] + tolerance 0.005
    onto2 = onto.extend(classes=[ClassDef(name="Pulley", parent="Part")])

An :class:`Ontology` is immutable: :meth:`Ontology.extend` returns a new one, the original is
unchanged. Hot-path checks (``is_a``, ``subclasses``, ``relation``, ``check_value``,
``check_relation``) are dict and set lookups; the graph is read once, by
:func:`wm_store.ontology_model.compile_graph`. Errors are :mod:`wm_store.errors` classes and
name the closest known name. How to extend the ontology: docs/guides/extend-the-ontology.md.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import re
from collections import defaultdict
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from types import MappingProxyType
from typing import Final

from rdflib import OWL, RDF, RDFS, XSD, Graph, Namespace, URIRef
from rdflib import Literal as RdfLiteral
from rdflib.util import guess_format

from wm_store.errors import (
    CardinalityError,
    OntologyError,
    PropertyValueError,
    RelationDomainError,
    UnknownClassError,
    UnknownPropertyError,
    UnknownRelationError,
    UnknownTemplateError,
    ValidationError,
)
from wm_store.ontology_model import ALL_KINDS as ALL_KINDS
from wm_store.ontology_model import (
    CLASS_NAME_RE,
    SCALAR_KINDS,
    SKM,
    TEMPLATE_NAME_RE,
    TYPED_KINDS,
    Declarations,
    compile_graph,
    did_you_mean,
    kind_of,
    typed_problem,
    with_article,
)
from wm_store.ontology_model import CardinalityRestriction as CardinalityRestriction
from wm_store.ontology_model import CardinalityShortfall as CardinalityShortfall
from wm_store.ontology_model import ClassInfo as ClassInfo
from wm_store.ontology_model import DataPropertyInfo as DataPropertyInfo
from wm_store.ontology_model import RelationInfo as RelationInfo
from wm_store.ontology_model import literal_from_value as literal_from_value
from wm_store.ontology_model import value_from_literal as value_from_literal
from wm_store.protocol import ClassDef, TemplateDef, Value

__all__ = [
    "ALL_KINDS",
    "CORE_FILE",
    "NAMESPACE",
    "ONTOLOGY_IRI",
    "CardinalityRestriction",
    "CardinalityShortfall",
    "ClassInfo",
    "DataPropertyInfo",
    "Ontology",
    "RelationInfo",
    "core_ontology_path",
    "literal_from_value",
    "value_from_literal",
]

ONTOLOGY_IRI: Final = "https://skimesh.dev/ontology"
NAMESPACE: Final = SKM
CORE_FILE: Final = "skimesh.ttl"
_GUIDE: Final = "docs/guides/extend-the-ontology.md"
_FILE_SUFFIXES: Final = (".ttl", ".owl", ".rdf", ".xml", ".nt", ".n3", ".jsonld")


def core_ontology_path() -> Path:
    """``skimesh.ttl``: in ``wm_store/ontologies/`` of a wheel, or ``ontologies/`` at the root
    of a source checkout (editable install)."""
    here = Path(__file__).resolve().parent
    candidates = (here / "ontologies" / CORE_FILE, here.parent / "ontologies" / CORE_FILE)
    for path in candidates:
        if path.is_file():
            return path
    raise OntologyError(f"core ontology not found; looked at {[str(p) for p in candidates]}")


def _one_of(names: Iterable[str]) -> str:
    items = sorted(names)
    return items[0] if len(items) == 1 else "one of " + ", ".join(items)


def _linearize(name: str, parents: Mapping[str, tuple[str, ...]]) -> tuple[str, ...]:
    """``name`` and its ancestors, nearest first (breadth-first); raises on a cycle."""
    order, seen, level = [name], {name}, list(parents.get(name, ()))
    while level:
        following: list[str] = []
        for p in level:
            if p == name:
                raise OntologyError(f"'{name}' is its own ancestor; break the cycle")
            if p not in seen:
                seen.add(p)
                order.append(p)
                following.extend(parents.get(p, ()))
        level = following
    return tuple(order)


def _humanize(name: str) -> str:
    return re.sub(r"(?<=[a-z0-9])(?=[A-Z])", " ", name).lower()


def _parse_into(graph: Graph, source: Path | str) -> None:
    if isinstance(source, str) and not (
        "\n" not in source and (source.endswith(_FILE_SUFFIXES) or Path(source).is_file())
    ):
        try:
            graph.parse(data=source, format="turtle")
        except Exception as exc:  # rdflib raises many types; all mean "bad Turtle"
            raise OntologyError(f"cannot parse the Turtle text: {exc}") from exc
        return
    path = Path(source)
    if not path.is_file():
        raise OntologyError(f"ontology file {path} does not exist")
    try:
        graph.parse(path, format=guess_format(str(path)) or "turtle")
    except Exception as exc:
        raise OntologyError(f"cannot parse {path}: {exc}") from exc


@functools.cache
def _default() -> Ontology:
    return Ontology.load(core_ontology_path())


class Ontology:
    """A loaded ontology. Build with :meth:`load` or :meth:`default`; never mutate ``graph``."""

    __slots__ = (
        "_added_classes",
        "_added_templates",
        "_ancestors",
        "_base",
        "_classes",
        "_decl",
        "_descendants",
        "_graph",
        "_ordered",
        "_rel_checks",
        "_rel_sub",
        "_rel_super",
        "_restrictions",
        "_tpl_by_class",
        "_value_kinds",
    )

    def __init__(
        self,
        decl: Declarations,
        graph: Graph,
        *,
        added_classes: tuple[ClassDef, ...] = (),
        added_templates: Mapping[str, TemplateDef] | None = None,
    ) -> None:
        self._decl, self._base = decl, graph
        self._added_classes = added_classes
        self._added_templates = dict(added_templates or {})
        self._graph: Graph | None = None
        parents = {n: c.parents for n, c in decl.classes.items()}
        for name, info in decl.classes.items():
            for p in info.parents:
                if p not in parents:
                    raise self._unknown_class(p, f"class '{name}': unknown parent", parents)
        self._ordered = {n: _linearize(n, parents) for n in parents}
        self._ancestors = {n: frozenset(o) for n, o in self._ordered.items()}
        self._classes = frozenset(parents)
        below: dict[str, set[str]] = {n: set() for n in parents}
        for n, ancestors in self._ancestors.items():
            for a in ancestors:
                below[a].add(n)
        self._descendants = {n: frozenset(d) for n, d in below.items()}
        declared: dict[str, list[CardinalityRestriction]] = defaultdict(list)
        for r in decl.restrictions:
            declared[r.declared_on].append(r)
        self._restrictions = {
            n: tuple(r for a in self._ordered[n] for r in declared.get(a, ())) for n in parents
        }
        rel_parents = {n: r.parents for n, r in decl.relations.items()}
        rel_order = {n: _linearize(n, rel_parents) for n in rel_parents}
        self._rel_super = {n: frozenset(o) for n, o in rel_order.items()}
        rel_below: dict[str, set[str]] = {n: set() for n in rel_parents}
        for n, supers in self._rel_super.items():
            for s in supers:
                rel_below[s].add(n)
        self._rel_sub = {n: frozenset(d) for n, d in rel_below.items()}
        self._rel_checks = {
            n: tuple(
                (decl.relations[a].domains, decl.relations[a].ranges, a)
                for a in order
                if decl.relations[a].domains or decl.relations[a].ranges
            )
            for n, order in rel_order.items()
        }
        # (kinds of scalars or list items, whether a bare scalar is accepted): "list" with
        # other kinds means a list of those; "any" (every kind) accepts scalars and lists
        self._value_kinds = {
            n: (
                p.kinds - {"list"} or SCALAR_KINDS,
                "list" not in p.kinds or p.kinds >= SCALAR_KINDS,
            )
            for n, p in decl.data_properties.items()
        }
        by_type: dict[str, list[str]] = defaultdict(list)
        for t in decl.templates.values():
            try:
                self._check_template(t)
            except (ValidationError, UnknownClassError) as exc:
                raise type(exc)(f"template '{t.name}': {exc}") from None
            by_type[t.type].append(t.name)
        self._tpl_by_class = {
            cls: names[0] if len(names) == 1 else f"Default{cls}"
            for cls, names in by_type.items()
            if len(names) == 1 or f"Default{cls}" in names
        }

    # ----------------------------------------------------------------------- construction

    @classmethod
    def load(cls, *sources: Path | str) -> Ontology:
        """Load Turtle files (or RDF/XML ``.owl``) and Turtle texts (a ``str`` that is not a
        file name) into one ontology. Raises OntologyError saying what is wrong and where."""
        if not sources:
            raise OntologyError("Ontology.load() needs at least one file or Turtle text")
        graph = Graph()
        for prefix, ns in (("skm", SKM), ("owl", OWL), ("rdfs", RDFS), ("xsd", XSD)):
            graph.bind(prefix, ns)
        for source in sources:
            _parse_into(graph, source)
        decl = compile_graph(graph)
        try:
            return cls(decl, graph)
        except ValidationError as exc:
            raise OntologyError(f"in the ontology files: {exc}") from exc

    @classmethod
    def default(cls) -> Ontology:
        """The core ontology (``ontologies/skimesh.ttl``), loaded once per process."""
        return _default()

    def extend(
        self, *, classes: Sequence[ClassDef] = (), templates: Sequence[TemplateDef] = ()
    ) -> Ontology:
        """A new ontology with ``classes`` (in order: one may be the parent of the next) and
        ``templates`` added; this one is unchanged. Templates added earlier by ``extend`` may
        be replaced, templates from the ontology files may not. Nothing is re-parsed."""
        if not classes and not templates:
            return self
        known = dict(self._decl.classes)
        taken = {**self._decl.iris, **{k: SKM[k] for k in TYPED_KINDS}}
        for c in classes:
            what = f"cannot define class {c.name!r}"
            if not CLASS_NAME_RE.fullmatch(c.name):
                raise OntologyError(
                    f"{what}: a class name starts with a capital letter and has only letters, "
                    "digits and '_' (e.g. 'SpurGear')"
                )
            if c.name in known:
                raise OntologyError(f"{what}: it is already defined; use it or pick a new name")
            if c.name in taken or c.name in self._decl.templates:
                owner = taken.get(c.name, "a template")
                raise OntologyError(f"{what}: the name is taken by <{owner}>")
            if c.parent not in known:
                raise self._unknown_class(c.parent, f"{what}: unknown parent", known)
            label = c.label or _humanize(c.name)
            known[c.name] = ClassInfo(
                name=c.name, parents=(c.parent,), label=label, comment=c.comment
            )
        all_templates = dict(self._decl.templates)
        added = dict(self._added_templates)
        for t in templates:
            what = f"cannot define template {t.name!r}"
            if not TEMPLATE_NAME_RE.fullmatch(t.name):
                raise OntologyError(
                    f"{what}: start with a letter, then letters, digits, '_' or '-' "
                    "(e.g. 'big-gear')"
                )
            if t.name in self._decl.templates and t.name not in added:
                raise OntologyError(
                    f"{what}: it comes from the ontology files and cannot be replaced at run "
                    "time; define a template with a new name"
                )
            if t.name in known or (t.name in taken and t.name not in all_templates):
                raise OntologyError(f"{what}: the name is taken by a class or property")
            copy = TemplateDef(
                name=t.name, type=t.type, label=t.label, properties=dict(t.properties)
            )
            all_templates[t.name] = added[t.name] = copy
        decl = dataclasses.replace(self._decl, classes=known, templates=all_templates)
        return Ontology(
            decl,
            self._base,
            added_classes=self._added_classes + tuple(classes),
            added_templates=added,
        )

    # ----------------------------------------------------------------------- graph views

    @property
    def namespace(self) -> Namespace:
        return SKM

    @property
    def graph(self) -> Graph:
        """Files plus extensions as one rdflib graph (built on first use; read-only)."""
        if self._graph is None:
            if self._added_classes or self._added_templates:
                merged = Graph()
                for prefix, ns in self._base.namespaces():
                    merged.bind(prefix, ns)
                merged += self._base
                merged += self._extension_graph()
                self._graph = merged
            else:
                self._graph = self._base
        return self._graph

    @property
    def extended_classes(self) -> tuple[ClassDef, ...]:
        """Classes added by :meth:`extend`, in order (for snapshots and persistence)."""
        return self._added_classes

    @property
    def extended_templates(self) -> tuple[TemplateDef, ...]:
        """Templates added (or replaced) by :meth:`extend`."""
        return tuple(self._added_templates.values())

    def _iri(self, name: str) -> URIRef:
        return self._decl.iris.get(name, SKM[name])

    def _extension_graph(self) -> Graph:
        g = Graph()
        g.bind("skm", SKM)
        g.bind("owl", OWL)
        head = URIRef(f"{ONTOLOGY_IRI}/runtime-extension")
        g.add((head, RDF.type, OWL.Ontology))
        g.add((head, OWL.imports, URIRef(ONTOLOGY_IRI)))
        for c in self._added_classes:
            iri, info = SKM[c.name], self._decl.classes[c.name]
            g.add((iri, RDF.type, OWL.Class))
            g.add((iri, RDFS.subClassOf, self._iri(c.parent)))
            g.add((iri, RDFS.label, RdfLiteral(info.label, lang="en")))
            if c.comment:
                g.add((iri, RDFS.comment, RdfLiteral(c.comment, lang="en")))
        for t in self._added_templates.values():
            iri = SKM[t.name]
            g.add((iri, RDF.type, OWL.NamedIndividual))
            g.add((iri, RDF.type, self._iri(t.type)))
            g.add((iri, SKM.template, RdfLiteral(True)))
            if t.label:
                g.add((iri, RDFS.label, RdfLiteral(t.label, lang="en")))
            for key, value in t.properties.items():
                g.add((iri, self._iri(key), literal_from_value(value)))
        return g

    def extension_turtle(self) -> str:
        """Turtle of what :meth:`extend` added ("" if nothing); loads with the core files."""
        if not (self._added_classes or self._added_templates):
            return ""
        return self._extension_graph().serialize(format="turtle")

    def __repr__(self) -> str:
        d = self._decl
        return (
            f"<Ontology {len(d.classes)} classes, {len(d.relations)} relations, "
            f"{len(d.data_properties)} data properties, {len(d.templates)} templates>"
        )

    # ----------------------------------------------------------------------- classes

    def _unknown_class(
        self, name: str, lead: str = "unknown", pool: Iterable[str] | None = None
    ) -> UnknownClassError:
        hint = did_you_mean(name, self._ancestors if pool is None else pool)
        return UnknownClassError(
            f"{lead} class {name!r}{hint} Classes come from ontologies/*.ttl or "
            f"define_class() ({_GUIDE})"
        )

    @property
    def classes(self) -> frozenset[str]:
        return self._classes

    def check_class(self, name: str) -> str:
        """``name`` if it is a class, else UnknownClassError with the closest names."""
        if name not in self._ancestors:
            raise self._unknown_class(name)
        return name

    def _up(self, cls: str) -> frozenset[str]:
        try:
            return self._ancestors[cls]
        except KeyError:
            raise self._unknown_class(cls) from None

    def class_info(self, name: str) -> ClassInfo:
        return self._decl.classes[self.check_class(name)]

    def is_a(self, cls: str, ancestor: str) -> bool:
        """True if ``cls`` is ``ancestor`` or a subclass of it (both must be classes)."""
        try:
            if ancestor in self._ancestors[cls]:
                return True
        except KeyError:
            raise self._unknown_class(cls) from None
        if ancestor not in self._ancestors:
            raise self._unknown_class(ancestor)
        return False

    def subclasses(self, cls: str) -> frozenset[str]:
        """``cls`` and every class below it."""
        try:
            return self._descendants[cls]
        except KeyError:
            raise self._unknown_class(cls) from None

    def superclasses(self, cls: str) -> tuple[str, ...]:
        """``cls`` and every class above it, nearest first."""
        try:
            return self._ordered[cls]
        except KeyError:
            raise self._unknown_class(cls) from None

    # ----------------------------------------------------------------------- relations

    @property
    def relations(self) -> Mapping[str, RelationInfo]:
        return MappingProxyType(self._decl.relations)

    def relation(self, name: str) -> RelationInfo:
        try:
            return self._decl.relations[name]
        except KeyError:
            hint = did_you_mean(name, self._decl.relations)
            raise UnknownRelationError(
                f"unknown relation {name!r}{hint} Relations: {sorted(self._decl.relations)}"
            ) from None

    def subproperties(self, name: str) -> frozenset[str]:
        """``name`` and every relation below it (what a query on ``name`` matches)."""
        self.relation(name)
        return self._rel_sub[name]

    def superproperties(self, name: str) -> frozenset[str]:
        """``name`` and every relation above it."""
        self.relation(name)
        return self._rel_super[name]

    def check_relation(self, subject_type: str, predicate: str, object_type: str) -> RelationInfo:
        """The relation, if a ``subject_type`` may ``predicate`` an ``object_type`` (domains and
        ranges of the relation and its super-properties); else RelationDomainError."""
        info = self.relation(predicate)
        if info.abstract:
            subs = sorted(self._rel_sub[predicate] - {predicate})
            raise RelationDomainError(
                f"'{predicate}' is abstract and cannot be set; use one of {subs}"
            )
        subject_up, object_up = self._up(subject_type), self._up(object_type)
        for domains, ranges, owner in self._rel_checks[predicate]:
            via = "" if owner == predicate else f" (from its super-property '{owner}')"
            for role, cls, up, allowed in (
                ("subject", subject_type, subject_up, domains),
                ("object", object_type, object_up, ranges),
            ):
                if allowed and up.isdisjoint(allowed):
                    raise RelationDomainError(
                        f"cannot relate {subject_type} --{predicate}--> {object_type}: the "
                        f"{role} of '{predicate}' must be {_one_of(allowed)}{via}, and {cls} is "
                        f"not ({' < '.join(self._ordered[cls])}); use another relation or class"
                    )
        return info

    # ----------------------------------------------------------------------- data properties

    @property
    def data_properties(self) -> Mapping[str, DataPropertyInfo]:
        return MappingProxyType(self._decl.data_properties)

    def data_property(self, name: str) -> DataPropertyInfo:
        try:
            return self._decl.data_properties[name]
        except KeyError:
            hint = did_you_mean(name, self._decl.data_properties)
            raise UnknownPropertyError(
                f"unknown data property {name!r}{hint} Declare it in the ontology ({_GUIDE})"
            ) from None

    def check_value(self, name: str, value: Value) -> None:
        """Raise PropertyValueError unless ``value`` fits property ``name``: its kind (an int is
        accepted as a float, a bool is not an int), its range widened by the tolerance, and
        the shape of typed values. ``None`` is always accepted; lists are checked item by item."""
        info = self._decl.data_properties.get(name) or self.data_property(name)
        kinds, scalar_ok = self._value_kinds[name]
        if value is None:
            return
        if isinstance(value, list):
            if "list" not in info.kinds:
                raise PropertyValueError(f"property '{name}' takes {_one_of(kinds)}, not a list")
            for i, item in enumerate(value):
                self._check_scalar(info, kinds, item, f"item {i} of ")
        elif not scalar_ok:
            raise PropertyValueError(
                f"property '{name}' takes a list of {_one_of(kinds)}, not {value!r}; "
                f"wrap it: [{value!r}]"
            )
        else:
            self._check_scalar(info, kinds, value, "")

    def _check_scalar(
        self, info: DataPropertyInfo, kinds: frozenset[str], value: object, where: str
    ) -> None:
        kind = kind_of(value)
        if kind is None or (kind not in kinds and not (kind == "int" and "float" in kinds)):
            got = f"{kind} {value!r}" if kind else f"{value!r} ({type(value).__name__})"
            raise PropertyValueError(
                f"{where}property '{info.name}' takes {_one_of(kinds)}, got {got}"
            )
        if isinstance(value, int | float) and not isinstance(value, bool):
            low, high, tol = info.minimum, info.maximum, info.tolerance
            if not math.isfinite(value):
                raise PropertyValueError(f"{where}property '{info.name}': {value} is not finite")
            if (low is not None and value < low - tol) or (high is not None and value > high + tol):
                bounds = f"[{'-inf' if low is None else low}, {'inf' if high is None else high}]"
                raise PropertyValueError(
                    f"{where}property '{info.name}' must be within {bounds} (tolerance {tol}); "
                    f"got {value!r}. Fix the value or its source, or widen the range in the "
                    "ontology"
                )
        elif kind in TYPED_KINDS:
            problem = typed_problem(value)  # type: ignore[arg-type]
            if problem:
                raise PropertyValueError(f"{where}property '{info.name}': {problem}")

    def check_property(self, cls: str, name: str, value: Value) -> None:
        """:meth:`check_value`, and the property's domain must admit an element of ``cls``."""
        info = self.data_property(name)
        up = self._up(cls)
        if info.domains and up.isdisjoint(info.domains):
            raise PropertyValueError(
                f"property '{name}' does not apply to {with_article(cls)}: "
                f"it is for {_one_of(info.domains)}"
            )
        self.check_value(name, value)

    # ----------------------------------------------------------------------- cardinality

    def restrictions(self, cls: str) -> tuple[CardinalityRestriction, ...]:
        """Cardinality restrictions on ``cls`` and its superclasses, nearest first."""
        self.check_class(cls)
        return self._restrictions[cls]

    def _applicable(
        self, cls: str, relation: str, object_cls: str | None, *, maximum: bool
    ) -> list[CardinalityRestriction]:
        self.check_class(cls)
        if object_cls is not None:
            self.check_class(object_cls)
        related = self.superproperties(relation) if maximum else self.subproperties(relation)
        out = []
        for r in self._restrictions[cls]:
            if r.relation not in related or (r.maximum if maximum else r.minimum) is None:
                continue
            if maximum:  # "max 1 hasA Door" bounds hasA to a MicrowaveDoor too
                ok = r.on_class is None or (
                    object_cls is not None and r.on_class in self._ancestors[object_cls]
                )
            else:  # "min 1 hasA MicrowaveDoor" implies min 1 hasA Door, and min 1 hasA
                ok = object_cls is None or (
                    r.on_class is not None and object_cls in self._ancestors[r.on_class]
                )
            if ok:
                out.append(r)
        return out

    def max_cardinality(self, cls: str, relation: str, object_cls: str | None = None) -> int | None:
        """The tightest maximum of ``relation`` triples for a ``cls`` (from ``cls`` or a
        superclass, on ``relation`` or a super-property); with ``object_cls``, qualified
        restrictions whose class covers it count too."""
        found = [r.maximum for r in self._applicable(cls, relation, object_cls, maximum=True)]
        return min((m for m in found if m is not None), default=None)

    def min_cardinality(self, cls: str, relation: str, object_cls: str | None = None) -> int | None:
        """The largest minimum of ``relation`` triples for a ``cls`` (restrictions on
        ``relation`` or a sub-property; qualified ones count when their class is ``object_cls``
        or below it, and always when ``object_cls`` is None)."""
        found = [r.minimum for r in self._applicable(cls, relation, object_cls, maximum=False)]
        return max((m for m in found if m is not None), default=None)

    def _count(self, r: CardinalityRestriction, existing: Iterable[tuple[str, str]]) -> int:
        subs = self._rel_sub[r.relation]
        return sum(
            1
            for predicate, obj in existing
            if predicate in subs and (r.on_class is None or self.is_a(obj, r.on_class))
        )

    def check_max_cardinality(
        self,
        subject_type: str,
        predicate: str,
        object_type: str,
        existing: Iterable[tuple[str, str]],
    ) -> None:
        """Raise CardinalityError if a ``subject_type`` that already has the ``existing``
        relations ``(predicate, object type)`` may not get one more ``predicate`` to an
        ``object_type``. The store calls this on every relation it adds."""
        current = list(existing)
        for r in self._applicable(subject_type, predicate, object_type, maximum=True):
            count = self._count(r, current)
            if r.maximum is not None and count + 1 > r.maximum:
                raise CardinalityError(
                    f"{with_article(subject_type)} may have {r.describe()}; it already has "
                    f"{count}. Unset one first (or move the object) in the same transaction"
                )

    def check_min_cardinality(
        self, cls: str, existing: Iterable[tuple[str, str]]
    ) -> tuple[CardinalityShortfall, ...]:
        """The minimum cardinalities a ``cls`` with these ``(predicate, object type)`` relations
        falls short of. Reported (e.g. by ``skimesh wm check``), not enforced per write: an
        element is added before its parts."""
        current = list(existing)
        out = []
        for r in self.restrictions(cls):
            if r.minimum:
                count = self._count(r, current)
                if count < r.minimum:
                    message = f"{with_article(cls)} should have {r.describe()}; it has {count}"
                    out.append(CardinalityShortfall(restriction=r, actual=count, message=message))
        return tuple(out)

    # ----------------------------------------------------------------------- templates

    @property
    def templates(self) -> Mapping[str, TemplateDef]:
        return MappingProxyType(self._decl.templates)

    def template(self, name: str) -> TemplateDef:
        """A template by name, or the default template of a class (``template("KitBox")``).
        Returns a copy: change its properties freely."""
        key = name if name in self._decl.templates else self._tpl_by_class.get(name)
        if key is None:
            if name in self._ancestors:
                several = sorted(t.name for t in self._decl.templates.values() if t.type == name)
                detail = f"several, ask by name: {several}" if several else "none defined"
                raise UnknownTemplateError(f"no default template for class {name!r} ({detail})")
            hint = did_you_mean(name, [*self._decl.templates, *self._tpl_by_class])
            raise UnknownTemplateError(f"unknown template {name!r}{hint}")
        t = self._decl.templates[key]
        props = {k: list(v) if isinstance(v, list) else v for k, v in t.properties.items()}
        return TemplateDef(name=t.name, type=t.type, label=t.label, properties=props)

    def _check_template(self, t: TemplateDef) -> None:
        self.check_class(t.type)
        for key, value in t.properties.items():
            self.check_property(t.type, key, value)
