"""The world-model client a run's skill gets as ``ctx.wm``: :class:`RunWm`.

A skill writes to the world model through its context (``cast(WmClient, ctx.wm)``, then
``transact``, ``update_element``, ``add_element``, ``set_relation``, ``observe``, ...). Every such
write belongs in the agent's event log (:class:`~skill_agent.protocol.WmWriteEntry`), whichever
method made it and from whichever skill method (``execute``, sensing, ``on_preempt``). So each
run gets a thin view of the agent's :class:`~wm_store.WmClient`:

- it *is* a ``WmClient`` (a subclass: every read and write method, typed, unchanged) that
  shares the agent client's transport, replica and settings: reads are served by the one
  replica of the agent, nothing is copied or followed twice;
- it overrides only :meth:`RunWm.request`, the one call every client write goes through (the
  convenience writes build a ``Transact`` and call ``transact``, which calls ``request``; a
  ``Transact`` sent with ``request`` directly passes there too): once the store has committed a
  transaction, the view reports its ops and revision to the run (``record``), before the client
  waits for its replica to show the write. A write that the store refused raises as before and
  is not reported; a write retried after a transport error is reported once (the store answers
  the retry of a committed transaction with the first reply).
"""

from __future__ import annotations

from collections.abc import Callable

from wm_store import WmClient
from wm_store.protocol import Op, Reply, Request, Transact, TransactReply

__all__ = ["RunWm", "WriteRecorder"]

WriteRecorder = Callable[[list[Op], int], None]
"""``(ops, revision)``: called once per transaction committed through the view; quick, on the
loop (the run turns it into an event-log entry)."""


class RunWm(WmClient):
    """A :class:`WmClient` whose committed transactions are reported to ``record`` (see the
    module doc). Create one per run with the agent's client; it holds no state of its own."""

    def __init__(self, client: WmClient, record: WriteRecorder) -> None:
        # Not WmClient.__init__ (it would build a second replica): share the client's
        # attributes (transport, replica, author, timeout, read_your_writes) as they are.
        vars(self).update(vars(client))
        self.client = client
        """The agent's client this view writes through."""
        self._record = record

    async def request(self, request: Request) -> Reply:
        """Send ``request`` like the client; a committed ``Transact`` is reported first."""
        reply = await super().request(request)
        if isinstance(request, Transact) and isinstance(reply, TransactReply):
            self._record(list(request.ops), reply.revision)
        return reply
