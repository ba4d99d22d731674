"""The compiled ontology: what :class:`~wm_store.ontology.Ontology` holds after reading its OWL
files (classes, relations, data properties, cardinalities, templates, IRIs and what
:meth:`~wm_store.ontology.Ontology.extend` added), as a msgspec Struct that decodes without
rdflib.

The OWL files stay the single source of truth: the store parses them (rdflib) and serves this
form on its read-only key (:class:`~wm_store.protocol.GetCompiledOntology`), so a replica or
client checks against the site's ontology, taught terms included, without an RDF library. The
closures (subclasses, sub-properties, inherited domains) are recomputed from it on decoding,
as they are after parsing. It also carries the store's core Turtle and log, so a process that
asks for the graph (a SPARQL query, ``wm export``) rebuilds it then. :data:`COMPILED_FORMAT`
changes whenever the Struct does: a reader refuses another one with an OntologyError instead
of misreading it.
"""

from __future__ import annotations

from typing import Final

import msgspec

from wm_store.ontology._terms import Declarations
from wm_store.protocol import ClassDef, OntologyDelta, TemplateDef

__all__ = ["COMPILED_FORMAT", "CompiledOntology", "decode_compiled", "encode_compiled"]

COMPILED_FORMAT: Final = 2
"""The version of :class:`CompiledOntology`'s layout."""


class CompiledOntology(msgspec.Struct, frozen=True, kw_only=True):
    """An ontology's declarations (as read from its graph) and run-time additions;
    ``digest`` is its core's. ``core`` and ``taught``: the core's Turtle and the ontology log
    it holds, from which the graph is rebuilt (rdflib) when one is asked for (SPARQL, Turtle
    export and import); empty when the sources were not given."""

    format: int = COMPILED_FORMAT
    declarations: Declarations
    added_classes: tuple[ClassDef, ...] = ()
    added_templates: tuple[TemplateDef, ...] = ()
    digest: str = ""
    core: str = ""
    taught: tuple[OntologyDelta, ...] = ()


class _Format(msgspec.Struct):
    format: int = 0


_encoder: Final = msgspec.msgpack.Encoder()
_decoder: Final = msgspec.msgpack.Decoder(CompiledOntology)
_format_decoder: Final = msgspec.msgpack.Decoder(_Format)


def encode_compiled(compiled: CompiledOntology) -> bytes:
    return _encoder.encode(compiled)


def decode_compiled(data: bytes) -> CompiledOntology:
    """The compiled ontology in ``data``; ValueError naming the format when it is another
    version's (or not a compiled ontology at all)."""
    try:
        found = _format_decoder.decode(data).format
    except msgspec.DecodeError as exc:
        raise ValueError(f"not a compiled ontology: {exc}") from None
    if found != COMPILED_FORMAT:
        raise ValueError(
            f"the compiled ontology has format {found}, this version reads format "
            f"{COMPILED_FORMAT}: run the same skimesh version as the store"
        )
    try:
        return _decoder.decode(data)
    except msgspec.DecodeError as exc:
        raise ValueError(f"the compiled ontology does not decode: {exc}") from None
