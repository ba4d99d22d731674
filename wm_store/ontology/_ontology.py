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
:func:`~wm_store.ontology._model.compile_graph`. Errors are :mod:`wm_store` classes and name
the closest known name. How to extend the ontology: docs/guides/extend-the-ontology.md.

This module loads files and Turtle texts, extends an ontology at run time and serializes the
extension; the checks are layers :class:`Ontology` builds on, each in its module::

    _taxonomy      classes and relations: closures, is-a, domains and ranges
    _cardinality   minimum and maximum cardinalities
    _values        data property values, templates (default individuals)
"""

from __future__ import annotations

import dataclasses
import functools
import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Final

from wm_store._errors import OntologyError, ValidationError
from wm_store.ontology._replay import text_digest
from wm_store.ontology._terms import (
    CLASS_NAME_RE,
    SKM_IRI,
    TEMPLATE_NAME_RE,
    TYPED_KINDS,
    ClassInfo,
    Declarations,
)
from wm_store.ontology._values import OntologyValues
from wm_store.protocol import ClassDef, ClassDefined, OntologyDelta, TemplateDef, TemplateDefined

if TYPE_CHECKING:
    from rdflib import Graph, Namespace

__all__ = ["CORE_FILE", "ONTOLOGY_IRI", "Ontology", "core_ontology_path"]

ONTOLOGY_IRI: Final = "https://skimesh.dev/ontology"
CORE_FILE: Final = "skimesh.ttl"


def core_ontology_path() -> Path:
    """``skimesh.ttl``: in ``wm_store/ontologies/`` of a wheel, or ``ontologies/`` at the root
    of a source checkout (editable install)."""
    here = Path(__file__).resolve().parent.parent  # the wm_store package
    candidates = (here / "ontologies" / CORE_FILE, here.parent / "ontologies" / CORE_FILE)
    for path in candidates:
        if path.is_file():
            return path
    raise OntologyError(f"core ontology not found; looked at {[str(p) for p in candidates]}")


def _humanize(name: str) -> str:
    return re.sub(r"(?<=[a-z0-9])(?=[A-Z])", " ", name).lower()


def _explicit_iris(iris: Mapping[str, str]) -> dict[str, str]:
    """The IRIs that are not the default one of their name (``skm:<name>``)."""
    return {name: iri for name, iri in iris.items() if iri != SKM_IRI + name}


@functools.cache
def _default() -> Ontology:
    return Ontology.load(core_ontology_path())


class Ontology(OntologyValues):
    """A loaded ontology. Build with :meth:`load` or :meth:`default`; never mutate ``graph``."""

    __slots__ = (
        "_added_classes",
        "_added_templates",
        "_base",
        "_digest",
        "_graph",
        "_parsed",
        "_sources",
        "_taught",
        "_texts",
    )

    def __init__(
        self,
        decl: Declarations,
        graph: Graph | None,
        *,
        added_classes: tuple[ClassDef, ...] = (),
        added_templates: Mapping[str, TemplateDef] | None = None,
        texts: tuple[str, ...] = (),
        taught: Graph | None = None,
        sources: tuple[str, tuple[OntologyDelta, ...]] | None = None,
    ) -> None:
        self._base = graph
        self._sources = sources
        """For a compiled ontology (no graph): the core Turtle and the log it holds."""
        self._parsed: Ontology | None = None
        self._texts = texts
        self._digest = text_digest("\n".join(texts)) if texts else ""
        self._taught = taught
        self._added_classes = added_classes
        self._added_templates = dict(added_templates or {})
        self._graph: Graph | None = None
        super().__init__(decl)

    # ----------------------------------------------------------------------- construction

    @classmethod
    def load(cls, *sources: Path | str) -> Ontology:
        """Load Turtle files (or RDF/XML ``.owl``) and Turtle texts (a ``str`` that is not a
        file name) into one ontology. Raises OntologyError saying what is wrong and where."""
        if not sources:
            raise OntologyError("Ontology.load() needs at least one file or Turtle text")
        from wm_store.ontology._graphs import parse_sources
        from wm_store.ontology._model import compile_graph

        graph, texts = parse_sources(sources)
        decl = compile_graph(graph)
        try:
            return cls(decl, graph, texts=texts)
        except ValidationError as exc:
            raise OntologyError(f"in the ontology files: {exc}") from exc

    @classmethod
    def from_compiled(cls, data: bytes) -> Ontology:
        """The ontology encoded by :meth:`compiled_bytes` (no rdflib): the same checks, taught
        terms and extensions as the one encoded, without its graph. Raises OntologyError
        when ``data`` is not a compiled ontology of this version's format."""
        from wm_store.ontology._compiled import decode_compiled

        try:
            compiled = decode_compiled(data)
            onto = cls(
                compiled.declarations,
                None,
                added_classes=compiled.added_classes,
                added_templates={t.name: t for t in compiled.added_templates},
                sources=(compiled.core, compiled.taught) if compiled.core else None,
            )
        except (ValueError, ValidationError) as exc:
            raise OntologyError(f"cannot read the compiled ontology: {exc}") from None
        onto._digest = compiled.digest
        return onto

    def compiled_bytes(
        self,
        core_digest: str = "",
        *,
        core: str = "",
        taught: Sequence[OntologyDelta] = (),
    ) -> bytes:
        """This ontology compiled (msgpack of :class:`CompiledOntology`), for
        :meth:`from_compiled`; ``core_digest``: the digest of the core it was built on
        (default: this ontology's own). ``core`` and ``taught``: the core's Turtle and the
        ontology log this ontology is (:func:`replay` of them), so the decoded one can rebuild
        its graph when asked (else it has none)."""
        from wm_store.ontology._compiled import CompiledOntology, encode_compiled

        return encode_compiled(
            CompiledOntology(
                declarations=self._decl,
                added_classes=self._added_classes,
                added_templates=tuple(self._added_templates.values()),
                digest=core_digest or self._digest,
                core=core,
                taught=tuple(taught),
            )
        )

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
        taken = {**self._decl.iris, **{k: SKM_IRI + k for k in TYPED_KINDS}}
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
        sources = None
        if self._sources is not None:  # the log of a compiled ontology grows with it
            core, log = self._sources
            more: list[OntologyDelta] = [ClassDefined(cls=c) for c in classes]
            more += [TemplateDefined(template=t) for t in templates]
            sources = (core, (*log, *more))
        return Ontology(
            decl,
            self._base,
            added_classes=self._added_classes + tuple(classes),
            added_templates=added,
            taught=self._taught,
            sources=sources,
        )

    def teach(self, terms: str | Graph, *, source: str = "") -> Ontology:
        """A new ontology with the Turtle ``terms`` added (classes, relations, data
        properties, restrictions, templates); this one is unchanged. Teaching only adds: the
        result must compile as a whole, and terms already present change nothing (the result
        then equals this ontology, see :meth:`same_terms`). ``source`` names the terms in
        errors. Raises OntologyError."""
        from rdflib import Graph

        from wm_store.ontology._graphs import bound_graph
        from wm_store.ontology._teaching import parse_terms, without_known_blank_nodes

        if self._base is None:
            return self._parsed_form("teach").teach(terms, source=source)
        own = self._base
        parsed = parse_terms(terms, source) if isinstance(terms, str) else terms
        parsed = without_known_blank_nodes(parsed + Graph(), own)
        base = bound_graph(own, parsed)
        taught = Graph()
        if self._taught is not None:
            taught += self._taught
        taught += parsed
        where = f"the terms from {source}" if source else "the taught terms"
        try:
            result = self._rebuilt(base, taught)
        except (OntologyError, ValidationError) as exc:
            raise OntologyError(f"{where} do not fit the ontology: {exc}") from exc
        return self if result.same_terms(self) else result

    def _rebuilt(self, base: Graph, taught: Graph) -> Ontology:
        """``base`` compiled, with the classes and templates :meth:`extend` added replayed on
        it, so an ontology taught nothing new compares equal to this one; when the new terms
        name one of those classes (or declare it again), the whole graph is compiled."""
        from wm_store.ontology._model import compile_graph

        added = list(self._added_templates.values())
        try:
            plain = Ontology(compile_graph(base), base, taught=taught)
            return plain.extend(classes=self._added_classes, templates=added)
        except (OntologyError, ValidationError):
            if not (self._added_classes or self._added_templates):
                raise
        decl = compile_graph(base + self._extension_graph())
        mine = self._decl  # what extend() made of them, as this ontology holds them
        decl = dataclasses.replace(
            decl,
            classes={**decl.classes, **{c.name: mine.classes[c.name] for c in self._added_classes}},
            templates={**decl.templates, **self._added_templates},
        )
        return Ontology(
            decl,
            base,
            added_classes=self._added_classes,
            added_templates=self._added_templates,
            taught=taught,
        )

    @property
    def digest(self) -> str:
        """SHA-256 of the texts this ontology was loaded from ("" for one built by
        :meth:`extend` or :meth:`teach`): equal digests mean the same core."""
        return self._digest

    def core_turtle(self) -> str:
        """The Turtle this ontology was loaded from (its one file's text, or the files'
        graph serialized), without what :meth:`extend` or :meth:`teach` added."""
        if len(self._texts) == 1 and not self._texts[0].startswith("\0"):
            return self._texts[0]
        if self._base is None:
            return self._parsed_form("core_turtle").core_turtle()
        return self._base.serialize(format="turtle")

    def same_terms(self, other: Ontology) -> bool:
        """True when both declare the same classes, properties, restrictions and templates
        (a name in the skimesh namespace counts the same whether or not its IRI is listed)."""
        mine, theirs = self._decl, other._decl
        if dataclasses.replace(mine, iris={}) != dataclasses.replace(theirs, iris={}):
            return False
        return _explicit_iris(mine.iris) == _explicit_iris(theirs.iris)

    # ----------------------------------------------------------------------- graph views

    @property
    def namespace(self) -> Namespace:
        from wm_store.ontology._literals import SKM

        return SKM

    @property
    def compiled(self) -> bool:
        """True for an ontology decoded from its compiled form (:meth:`from_compiled`): its
        checks are those of its files; what needs its graph (:attr:`graph`, :meth:`teach`,
        the extension's Turtle) parses its sources first (rdflib)."""
        return self._base is None

    def _parsed_form(self, what: str) -> Ontology:
        """A compiled ontology parsed: its core Turtle and log replayed with rdflib (once), for
        what needs the graph. OntologyError when it was compiled without them."""
        if self._parsed is None:
            if self._sources is None:
                raise OntologyError(
                    f"{what} needs the ontology's graph, and this one was decoded from a compiled "
                    "form without its sources: load the OWL files with Ontology.load() (rdflib)"
                )
            from wm_store.ontology._replay import replay

            core, log = self._sources
            self._parsed = replay(Ontology.load(core), log)
        return self._parsed

    @property
    def graph(self) -> Graph:
        """Files plus extensions as one rdflib graph (built on first use; read-only)."""
        if self._base is None:
            return self._parsed_form("graph").graph
        if self._graph is None:
            own = self._base
            if self._added_classes or self._added_templates:
                from wm_store.ontology._graphs import bound_graph

                self._graph = bound_graph(own, self._extension_graph())
            else:
                self._graph = own
        return self._graph

    @property
    def extended_classes(self) -> tuple[ClassDef, ...]:
        """Classes added by :meth:`extend`, in order (for snapshots and persistence)."""
        return self._added_classes

    @property
    def extended_templates(self) -> tuple[TemplateDef, ...]:
        """Templates added (or replaced) by :meth:`extend`."""
        return tuple(self._added_templates.values())

    def _extension_graph(self) -> Graph:
        from wm_store.ontology._graphs import extension_graph

        return extension_graph(
            ONTOLOGY_IRI,
            self._added_classes,
            self._added_templates.values(),
            self._decl.classes,
            self._decl.iris,
        )

    def extension_graph(self) -> Graph:
        """What :meth:`teach` and :meth:`extend` added, as one graph (empty if nothing)."""
        from wm_store.ontology._graphs import bound_graph

        if self._base is None:
            return self._parsed_form("extension_graph").extension_graph()
        g = bound_graph()
        if self._added_classes or self._added_templates:
            g += self._extension_graph()
        if self._taught is not None:
            g += self._taught
        return g

    def extension_turtle(self) -> str:
        """Turtle of what :meth:`teach` and :meth:`extend` added ("" if nothing); loads with
        the core files."""
        if self._base is None:
            return self._parsed_form("extension_turtle").extension_turtle()
        if not (self._added_classes or self._added_templates or self._taught):
            return ""
        return self.extension_graph().serialize(format="turtle")

    def __repr__(self) -> str:
        d = self._decl
        return (
            f"<Ontology {len(d.classes)} classes, {len(d.relations)} relations, "
            f"{len(d.data_properties)} data properties, {len(d.templates)} templates>"
        )
