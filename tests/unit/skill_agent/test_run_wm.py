"""RunWm, the world-model view a run's skill gets as ``ctx.wm``: reads are the agent client's
(one replica), every committed transaction is reported once, refused ones are not."""

from __future__ import annotations

import pytest

from skill_agent.runtime import RunWm
from wm_store import WmClient, WmError
from wm_store.protocol import Op, Transact, TransactReply, UpdateElement

from .conftest import Kitting

pytestmark = pytest.mark.anyio


async def test_reads_share_the_agents_replica_and_committed_writes_are_reported(
    kitting: Kitting,
) -> None:
    seen: list[tuple[list[Op], int]] = []
    view = RunWm(kitting.wm, lambda ops, revision: seen.append((ops, revision)))
    gear, kit = kitting["gear1"], kitting["kit"]
    assert isinstance(view, WmClient) and view.client is kitting.wm
    assert view.replica is kitting.wm.replica and view.author == kitting.wm.author
    assert view.get_element(gear) == kitting.wm.get_element(gear)

    updated = await view.update_element(gear, {"mass": 0.4})
    assert kitting.wm.get_element(gear).properties["mass"] == 0.4  # read your writes, shared
    relabel: list[Op] = [UpdateElement(id=kit, label="kit-2")]
    direct = await view.request(Transact(ops=relabel, txn_id="direct-1"))
    assert isinstance(direct, TransactReply)
    with pytest.raises(WmError):
        await view.update_element("Gear-404", {"mass": 1.0})  # refused: not reported
    await kitting.wm.update_element(gear, {"mass": 0.5})  # the agent's own client: not a run's

    assert seen == [
        ([UpdateElement(id=gear, properties={"mass": 0.4})], updated),
        (relabel, direct.revision),
    ]
    assert updated < direct.revision < kitting.wm.revision
