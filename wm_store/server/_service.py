"""Request -> reply dispatch of the world-model store, independent of the transport.

:class:`WmService` answers every :data:`~wm_store.protocol.Request` with a
:data:`~wm_store.protocol.Reply`. It never raises for bad input: malformed bytes (including
invalid UTF-8 and nesting too deep), unknown tags, wrong field types, unknown names, rule
violations and oversized messages all become a :class:`meshlink.rpc.ErrorReply` naming the
problem, and the state is unchanged. One :class:`meshlink.rpc.RequestHandler` per queryable
(``wm/rpc`` and the read-only ``wm/query``) decodes, limits the size and encodes; the Zenoh
server and the in-memory test transport both sit on top of them.

Codes: a :class:`~wm_store.WmError`'s own ``code``; meshlink's standard ``bad_request``
(malformed request, or a ``ValueError``/``TypeError``/``KeyError`` raised by the request),
``too_large`` and ``internal`` (any other exception, logged).
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING

import msgspec

from meshlink.rpc import (
    BAD_REQUEST,
    DEFAULT_MAX_REQUEST_BYTES,
    INTERNAL,
    ErrorReply,
    RequestHandler,
    WireError,
    encode,
)
from wm_store._errors import ElementNotFoundError, ProtocolError, WmError
from wm_store.protocol import (
    CardinalityReply,
    ChangesSince,
    CheckCardinality,
    CompiledOntologyReply,
    ElementsReply,
    GetCompiledOntology,
    GetElements,
    GetOntology,
    Info,
    Parent,
    Relations,
    RelationsReply,
    Reply,
    Request,
    Resolve,
    Snapshot,
    Sparql,
    Transact,
)
from wm_store.rdf import SparqlWorker
from wm_store.scene import match_relations, min_cardinality_violations, resolve
from wm_store.server._store import WmStore

if TYPE_CHECKING:
    from wm_store.ontology import Ontology

__all__ = ["MAX_REQUEST_BYTES", "WmService"]

_log = logging.getLogger(__name__)

MAX_REQUEST_BYTES = DEFAULT_MAX_REQUEST_BYTES


class WmService:
    """Answers world-model requests against one :class:`~wm_store.server.WmStore`.

    ``rpc`` and ``query`` are the request handlers of ``wm/rpc`` and of the read-only
    ``wm/query`` (:meth:`~meshlink.rpc.RequestHandler.serve_on` serves one on a key); both
    refuse requests longer than ``max_request_bytes``.
    """

    def __init__(self, store: WmStore, *, max_request_bytes: int = MAX_REQUEST_BYTES) -> None:
        self.store = store
        self.max_request_bytes = max_request_bytes
        config = store.config
        self._sparql = SparqlWorker(
            timeout=config.sparql_timeout,
            max_text=config.sparql_max_text,
            max_rows=config.sparql_max_rows,
            core=store.core_ontology,
        )
        self.rpc: RequestHandler[Request, Reply] = RequestHandler(
            Request, self.handle, max_request_bytes=max_request_bytes, name="wm/rpc"
        )
        self.query: RequestHandler[Request, Reply] = RequestHandler(
            Request, self._handle_read, max_request_bytes=max_request_bytes, name="wm/query"
        )
        self._compiled: tuple[Ontology, int, bytes] | None = None
        """The store's ontology, the length of its log and its compiled bytes (encoded once
        per ontology)."""

    def _compiled_ontology(self) -> CompiledOntologyReply:
        """The store's ontology compiled, with its core's Turtle and log (so a client can
        rebuild the graph if it needs one) and how much of the log that covers."""
        store, log = self.store, self.store.state.ontology_log
        cached = self._compiled
        if cached is None or cached[0] is not store.ontology or cached[1] != len(log):
            digest, core = store.core_ontology()
            data = store.ontology.compiled_bytes(digest, core=core, taught=log)
            self._compiled = cached = (store.ontology, len(log), data)
        return CompiledOntologyReply(
            revision=store.state.revision,
            taught=len(log),
            core_digest=store.core_digest,
            compiled=cached[2],
        )

    def _sync(self, revision: int | None) -> tuple[str, bytes, int]:
        """What brings the SPARQL worker's copy of the scene from ``revision`` to the store's:
        the changes since (cheap), or the whole scene when it has none or they are gone."""
        store = self.store
        if revision is not None and revision >= store.oldest_revision():
            payloads, last = store.encoded_changes_since(revision)
            return "changes", encode(payloads) if payloads else b"", last
        snapshot = store.snapshot()
        return "scene", encode(snapshot), snapshot.revision

    async def aclose(self) -> None:
        """End what the service started (the SPARQL worker process, if any)."""
        await self._sparql.aclose()

    async def handle_bytes(self, data: bytes, *, read_only: bool = False) -> tuple[bytes, bool]:
        """Decode, answer and encode one request. Returns ``(reply bytes, ok)``.

        ``read_only`` refuses transactions (the ``wm/query`` endpoint)."""
        return await (self.query if read_only else self.rpc).handle_bytes(data)

    async def handle(self, request: Request) -> Reply:
        """Answer one decoded request; the store's errors become :class:`ErrorReply`. The
        SPARQL worker's child is stopped while any other request is served."""
        try:
            if isinstance(request, Sparql):
                return await self._dispatch(request)
            with self._sparql.serving():
                return await self._dispatch(request)
        except WmError as exc:
            return ErrorReply(code=exc.code, message=str(exc))
        except (ValueError, TypeError, KeyError) as exc:
            _log.warning("request %s refused: %s", type(request).__name__, exc)
            return ErrorReply(code=BAD_REQUEST, message=f"{type(exc).__name__}: {exc}")

    async def handle_write(self, data: bytes, writer: str) -> tuple[bytes, bool]:
        """Answer one request of ``wm/write/<writer>``: a transaction, committed with
        ``writer`` as its author whatever it claims (under the router's ACL only ``writer``
        can query that key, so the author is its identity). Returns ``(reply bytes, ok)``."""
        reply: Reply
        try:
            request = self.rpc.decoder.decode(data)
        except WireError as exc:
            reply = ErrorReply(code=exc.code, message=str(exc))
        else:
            if isinstance(request, Transact):
                try:
                    reply = await self.handle(msgspec.structs.replace(request, author=writer))
                except Exception as exc:  # as the RPC layer does: answered, logged
                    _log.exception("wm/write/%s: the transaction failed", writer)
                    reply = ErrorReply(code=INTERNAL, message=f"{type(exc).__name__}: {exc}")
            else:
                reply = ErrorReply(
                    code=ProtocolError.code,
                    message=f"wm/write/{writer} takes transactions only: send reads to wm/query",
                )
        return encode(reply), not isinstance(reply, ErrorReply)

    async def _handle_read(self, request: Request) -> Reply:
        if isinstance(request, Transact):
            return ErrorReply(
                code=ProtocolError.code,
                message="this endpoint is read-only: send transactions to wm/rpc",
            )
        return await self.handle(request)

    async def _dispatch(self, request: Request) -> Reply:
        store = self.store
        state = store.state
        match request:
            case GetElements(ids=ids):
                missing = [i for i in ids if i not in state]
                if missing:
                    raise ElementNotFoundError(f"no element(s) {', '.join(missing)}")
                return ElementsReply(
                    revision=state.revision, elements=[state.elements[i] for i in ids]
                )
            case Resolve(query=query, limit=limit):
                found = resolve(state, store.ontology, query, limit)
                return ElementsReply(revision=state.revision, elements=found)
            case Relations(subject=s, predicate=p, object=o, include_subproperties=sub):
                rels = match_relations(state, store.ontology, s, p, o, include_subproperties=sub)
                return RelationsReply(revision=state.revision, relations=rels)
            case Parent(id=element_id):
                if element_id not in state:
                    raise ElementNotFoundError(f"no element {element_id!r}")
                parent = state.parent(element_id)
                return RelationsReply(
                    revision=state.revision, relations=[] if parent is None else [parent]
                )
            case Sparql(query=text, bindings=bindings):
                return await self._sparql.query(self._sync, text, bindings)
            case Transact():
                return await store.transact(request)
            case Snapshot(revision=revision):
                snap = store.snapshot(revision)
                return msgspec.structs.replace(snap, core_digest=store.core_digest)
            case ChangesSince(revision=revision, limit=limit):
                return store.changes_since(revision, limit)
            case Info():
                return store.info()
            case GetOntology():
                return store.ontology_reply()
            case GetCompiledOntology():
                return self._compiled_ontology()
            case CheckCardinality(ids=ids):
                checked, violations = min_cardinality_violations(state, store.ontology, ids)
                return CardinalityReply(
                    revision=state.revision, checked=checked, violations=violations
                )
        raise ProtocolError(f"unsupported request {type(request).__name__}")  # pragma: no cover
