"""Replaying what was taught, without rdflib until a taught Turtle text needs parsing.

The store's ontology is its core file plus an ordered list of :data:`OntologyDelta`: classes
(:class:`ClassDefined`), templates (:class:`TemplateDefined`) and Turtle terms
(:class:`TermsDefined`: anything an ontology file can declare). :func:`replay` rebuilds it from
that list, the same way in the store, in every replica and after a restart, so every process of
the mesh checks against one ontology. Classes and templates extend an ontology without parsing
anything (a compiled ontology, :meth:`Ontology.from_compiled`, takes them too); taught terms are
Turtle and need the rdflib-backed ontology of :meth:`Ontology.load`.

:func:`text_digest` is the digest a snapshot carries, so a client knows whether its own core
file is the store's.
"""

from __future__ import annotations

import hashlib
from collections.abc import Iterable
from typing import TYPE_CHECKING

from wm_store.protocol import (
    ClassDefined,
    OntologyDelta,
    TemplateDefined,
    TermsDef,
    TermsDefined,
)

if TYPE_CHECKING:
    from rdflib import Graph

    from wm_store.ontology._ontology import Ontology

__all__ = ["replay", "text_digest"]


def text_digest(text: str) -> str:
    """SHA-256 (hex) of a text, as a snapshot's ``core_digest``."""
    return hashlib.sha256(text.encode()).hexdigest()


def replay(base: Ontology, log: Iterable[OntologyDelta]) -> Ontology:
    """``base`` with every delta of ``log`` applied in order (what the store did). Consecutive
    taught texts are merged and compiled once: replaying a long log costs one compile per run
    of texts, not one per text."""
    onto = base
    texts: list[TermsDef] = []

    def flush(onto: Ontology) -> Ontology:
        if not texts:
            return onto
        if len(texts) == 1:
            merged: Graph | str = texts[0].turtle
        else:
            from rdflib import Graph  # only a run of several taught texts is merged here

            from wm_store.ontology._teaching import parse_terms

            merged = Graph()
            for terms in texts:
                merged += parse_terms(terms.turtle, terms.source)
        sources = ", ".join(t.source for t in texts if t.source)
        texts.clear()
        return onto.teach(merged, source=sources)

    for delta in log:
        match delta:
            case TermsDefined(terms=terms):
                texts.append(terms)
            case ClassDefined(cls=c):
                onto = flush(onto).extend(classes=[c])
            case TemplateDefined(template=t):
                onto = flush(onto).extend(templates=[t])
    return flush(onto)
