"""Writing more ops than one transaction takes (:func:`wm_store.transact_in_batches`): refs
of earlier batches are rebound to their ids, a refused batch leaves the earlier ones and says
which it was, and the same import run again goes on from where it stopped."""

from __future__ import annotations

import pytest

from tests.unit.wm_store.stores import memory_client
from wm_store import UnknownClassError, transact_in_batches
from wm_store.protocol import AddElement, Op, Relation, SetRelation

pytestmark = pytest.mark.anyio


def ops(n: int, *, bad_at: int | None = None) -> list[Op]:
    """A box, then ``n`` gears in it (each op naming the box by its ref), then a relation."""
    out: list[Op] = [AddElement(type="Box", label="box", ref="$box")]
    for i in range(n):
        kind = "Gaer" if i == bad_at else "Gear"
        out.append(
            AddElement(
                type=kind, label=f"g{i}", ref=f"$g{i}", relations=[Relation("$box", "contain", "$")]
            )
        )
    out.append(SetRelation(subject="$box", predicate="near", object="$g0"))
    return out


async def test_refs_cross_batches_and_every_op_lands() -> None:
    async with memory_client() as wm:
        seen: list[tuple[int, int]] = []
        ids = await transact_in_batches(
            wm, ops(25), size=10, txn_prefix="t1", progress=lambda d, t, r: seen.append((d, t))
        )
        assert seen == [(10, 27), (20, 27), (27, 27)]
        box = ids["$box"]
        assert len(wm.query_relation(box, "contain", "")) == 25
        assert wm.query_relation(box, "near", ids["$g0"])


async def test_a_refused_batch_keeps_the_earlier_ones_and_a_rerun_goes_on() -> None:
    async with memory_client() as wm:
        with pytest.raises(UnknownClassError, match=r"batch 2 \(ops 11-20 of 27\)"):
            await transact_in_batches(wm, ops(25, bad_at=12), size=10, txn_prefix="t2")
        assert len(wm.resolve_element(type="Gear")) == 9  # batch 1: the box and 9 gears
        ids = await transact_in_batches(wm, ops(25), size=10, txn_prefix="t2")
        assert len(wm.resolve_element(type="Gear")) == 25, "no gear twice, none missing"
        assert len(wm.query_relation(ids["$box"], "contain", "")) == 25
