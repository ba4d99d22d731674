"""Errors of the world-model package. Every exception raised by ``wm_store`` derives from
:class:`WmError`, so callers can catch the package as a whole.

Hierarchy::

    WmError
    ├── OntologyError                  the ontology cannot be loaded or is inconsistent
    │   ├── UnknownClassError          a class the ontology does not define (names the closest)
    │   ├── UnknownRelationError       a relation name the ontology does not define
    │   ├── UnknownPropertyError       a data property name the ontology does not define
    │   └── UnknownTemplateError       no default individual of that name
    ├── ValidationError                a request is well-formed but breaks a rule; nothing changes
    │   ├── RelationDomainError        a relation's subject or object has the wrong class
    │   ├── TreeShapeError             a spatial relation would make a cycle or a second parent
    │   ├── PropertyValueError         wrong kind of value, or out of the range the ontology states
    │   ├── CardinalityError           more (or fewer) relations than the ontology allows
    │   ├── ElementNotFoundError       no element with that id
    │   ├── DuplicateIdError           an explicit id that is taken or was used before
    │   ├── NameConflictError          a name that would be one element's id and another's label
    │   ├── DuplicateLabelError        a label another element of its kind has already
    │   ├── ConflictError              compare-and-set failed: the element or store moved on
    │   ├── ForbiddenError             an agent's write to another agent's registered elements
    │   └── QueryLimitError            a SPARQL query over a limit: text size, time, rows, queue
    ├── ProtocolError                  bytes that do not decode to a request/reply of this schema,
    │                                  or a request over the size limit
    ├── HistoryCompactedError          changes-since asked for revisions no longer kept
    ├── StorageError                   the durable log or a snapshot cannot be read or written
    │   └── CorruptLogError            a record in the middle of the log fails its CRC
    ├── TransportError                 the store cannot be reached (no reply, timeout, closed)
    │   └── RevisionTimeoutError       a revision did not reach this replica in time (also a
    │                                  ``TimeoutError``)
    └── RemoteError                    the store answered with an error (keeps its code)

Each error has a stable ``code`` (used on the wire in :class:`meshlink.rpc.ErrorReply`), and
messages say what to do where that is known. The store answers malformed and oversized requests
with meshlink's standard codes ``bad_request`` and ``too_large``, which the client raises as
:class:`ProtocolError` (:data:`WM_CODES`).
"""

from __future__ import annotations

from typing import Any

from meshlink.rpc import (
    BAD_REQUEST,
    TOO_LARGE,
    UNAVAILABLE,
    ErrorFactory,
    errors_by_code,
    from_message,
)

__all__ = [
    "WM_CODES",
    "CardinalityError",
    "ConflictError",
    "CorruptLogError",
    "DuplicateIdError",
    "DuplicateLabelError",
    "ElementNotFoundError",
    "ForbiddenError",
    "HistoryCompactedError",
    "NameConflictError",
    "OntologyError",
    "PropertyValueError",
    "ProtocolError",
    "QueryLimitError",
    "RelationDomainError",
    "RemoteError",
    "RevisionTimeoutError",
    "StorageError",
    "TransportError",
    "TreeShapeError",
    "UnknownClassError",
    "UnknownPropertyError",
    "UnknownRelationError",
    "UnknownTemplateError",
    "ValidationError",
    "WmError",
    "remote_error",
]


class WmError(Exception):
    """Root of every world-model error."""

    code: str = "wm_error"


class OntologyError(WmError):
    code = "ontology_error"


class UnknownClassError(OntologyError):
    code = "unknown_class"


class UnknownRelationError(OntologyError):
    code = "unknown_relation"


class UnknownPropertyError(OntologyError):
    code = "unknown_property"


class UnknownTemplateError(OntologyError):
    code = "unknown_template"


class ValidationError(WmError):
    code = "validation_error"


class RelationDomainError(ValidationError):
    code = "relation_domain"


class TreeShapeError(ValidationError):
    code = "tree_shape"


class PropertyValueError(ValidationError):
    code = "property_value"


class CardinalityError(ValidationError):
    code = "cardinality"


class ElementNotFoundError(ValidationError):
    code = "not_found"


class DuplicateIdError(ValidationError):
    code = "duplicate_id"


class NameConflictError(ValidationError):
    """A name would be the id of one element and the label of another (the message names
    both): a label equal to another element's id, or an explicit id equal to another's label."""

    code = "name_conflict"


class DuplicateLabelError(ValidationError):
    """A label that another element of the same kind has already (scene elements among
    themselves, agents among themselves; the message names that element)."""

    code = "duplicate_label"


class ConflictError(ValidationError):
    code = "conflict"


class QueryLimitError(ValidationError):
    code = "query_limit"


class ForbiddenError(ValidationError):
    """A skill agent's transaction would change what another agent registered: its Agent or
    Skill elements, the robot it controls or that robot's devices (the message names both)."""

    code = "forbidden"


class ProtocolError(WmError):
    code = "protocol_error"


class HistoryCompactedError(WmError):
    code = "history_compacted"


class StorageError(WmError):
    code = "storage_error"


class CorruptLogError(StorageError):
    code = "corrupt_log"


class TransportError(WmError):
    code = "transport_error"


class RevisionTimeoutError(TransportError, TimeoutError):
    """A revision the caller waits for did not reach the local replica in time: the store's
    change stream and its ``changes-since`` answers are too slow or cut off. Also a
    ``TimeoutError``, so ``except TimeoutError`` still catches it."""

    code = "revision_timeout"


class RemoteError(WmError):
    """The store answered with an error. ``remote_code`` is the code of the error it raised."""

    code = "remote_error"

    def __init__(self, remote_code: str, message: str) -> None:
        super().__init__(f"[{remote_code}] {message}")
        self.remote_code = remote_code
        self.message = message


_BY_CODE = errors_by_code(
    WmError,
    OntologyError,
    UnknownClassError,
    UnknownRelationError,
    UnknownPropertyError,
    UnknownTemplateError,
    ValidationError,
    RelationDomainError,
    TreeShapeError,
    PropertyValueError,
    CardinalityError,
    ElementNotFoundError,
    DuplicateIdError,
    NameConflictError,
    DuplicateLabelError,
    ConflictError,
    ForbiddenError,
    QueryLimitError,
    ProtocolError,
    HistoryCompactedError,
    StorageError,
    CorruptLogError,
    TransportError,
)


def _too_large(reply: Any) -> WmError:
    return ProtocolError(f"{reply.message}; split the transaction")


WM_CODES: dict[str, ErrorFactory] = {
    **_BY_CODE,
    BAD_REQUEST: from_message(ProtocolError),
    TOO_LARGE: _too_large,
    UNAVAILABLE: from_message(TransportError),
}
"""Error code -> the local exception, for :func:`meshlink.rpc.raise_for_error`: each
:class:`WmError` code gives its own class (so ``except ConflictError`` works across the wire),
meshlink's ``bad_request`` and ``too_large`` a :class:`ProtocolError`. Other codes
(``internal``, a newer store's) give a :class:`RemoteError` through :func:`remote_error`."""


def remote_error(reply: Any) -> WmError:
    """A :class:`RemoteError` keeping the code of an error reply :data:`WM_CODES` does not map."""
    return RemoteError(reply.code, reply.message)
