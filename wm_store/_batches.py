"""Writing more ops than one transaction takes: :func:`transact_in_batches`.

A store refuses a transaction of more than ``StoreConfig.max_ops`` ops (10,000 by default),
and a big transaction holds the store's loop for its whole length. A large import (a site's
Turtle file of 100,000 elements) is therefore written in batches, each its own transaction:

- ops keep their order; an op that names an element by the ``ref`` an earlier batch added
  (``$box`` in a relation) gets the id that batch's reply assigned;
- each batch has a transaction id made from ``txn_prefix`` and its number, so running the same
  import again (after a lost connection, a crash of the client) re-sends the batches already
  committed under their ids, which the store answers with their first replies, and goes on
  where it stopped: an import is **resumable**, not all-or-nothing (batches already committed
  stay if a later one is refused, and the error says which batch);
- ``progress(done, total, revision)`` is called after each batch.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import TYPE_CHECKING

import msgspec

from wm_store._errors import WmError
from wm_store.protocol import AddElement, Op, Relation, SetRelation, UnsetRelation

if TYPE_CHECKING:
    from wm_store._client import WmClient

__all__ = ["transact_in_batches"]

Progress = Callable[[int, int, int], None]


def _rebind_relation(r: Relation, ids: Mapping[str, str]) -> Relation:
    return Relation(ids.get(r.subject, r.subject), r.predicate, ids.get(r.object, r.object))


def _rebind(op: Op, ids: Mapping[str, str]) -> Op:
    """``op`` with the refs of earlier batches replaced by the ids they got."""
    if not ids:
        return op
    match op:
        case AddElement(relations=relations) if relations:
            return msgspec.structs.replace(
                op, relations=[_rebind_relation(r, ids) for r in relations]
            )
        case SetRelation() | UnsetRelation():
            return msgspec.structs.replace(
                op, subject=ids.get(op.subject, op.subject), object=ids.get(op.object, op.object)
            )
        case _:
            return op


async def transact_in_batches(
    client: WmClient,
    ops: Sequence[Op],
    *,
    size: int = 5000,
    txn_prefix: str,
    progress: Progress | None = None,
) -> dict[str, str]:
    """Commit ``ops`` in batches of ``size`` (see the module doc); returns the ids assigned,
    by ref, over every batch. Raises the store's error, prefixed with the batch that failed."""
    ids: dict[str, str] = {}
    total = len(ops)
    for start in range(0, total, size):
        number = start // size + 1
        batch = [_rebind(op, ids) for op in ops[start : start + size]]
        try:
            reply = await client.transact(batch, txn_id=f"{txn_prefix}-{number}")
        except WmError as exc:
            raise type(exc)(
                f"batch {number} (ops {start + 1}-{start + len(batch)} of {total}): {exc}; "
                f"the {start} ops before it are committed, and running the same import again "
                "goes on from here"
            ) from exc
        ids.update({k: v for k, v in reply.ids.items() if not k.startswith("#")})
        if progress is not None:
            progress(start + len(batch), total, reply.revision)
    return ids
