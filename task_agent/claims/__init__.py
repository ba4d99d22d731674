"""Claims of running tasks on robots and objects, so several tasks share a site safely.

:class:`ClaimBook` holds each running task's :class:`Claim` (the agents it commands, the
objects it acts on) and makes a task whose plan needs something another task holds wait,
highest priority first, all or nothing (no deadlock); :meth:`ClaimBook.busy` lets a task plan
around what others hold. Modules: ``_book``.
"""

from ._book import Claim as Claim
from ._book import ClaimBook as ClaimBook
from ._book import Waiting as Waiting

__all__ = ["Claim", "ClaimBook", "Waiting"]
