"""The state of a running :class:`~mujoco_sim.SimWorld`, by the thread that owns it.

:class:`LoopState` is written only on the event loop, with one exception: during a fast run
the simulation thread takes the jobs queued in ``inbox`` (a deque: appends and pops are
thread-safe). Between batches or ticks it also reads ``next_alarm``, ``reporting``, ``calls``
and copies ``alarms`` (single reads, atomic under the GIL), which is why they are plain
attributes. :class:`ThreadState` is written only in the simulation thread during a thread
call; the loop reads ``latest`` (one reference, atomic) and resets the other fields only
between thread calls, when the simulation thread is not running.
"""

from __future__ import annotations

import math
import threading
from collections import deque

import anyio

from mujoco_sim._snapshot import Snapshot
from mujoco_sim.control._job import Job

__all__ = ["LoopState", "ThreadState"]


class LoopState:
    """What the event loop owns: queued and waiting jobs, alarms, the last delivered snapshot,
    the failure and the runner's counters."""

    __slots__ = (
        "alarms",
        "busy",
        "calls",
        "failure",
        "handovers",
        "inbox",
        "news",
        "next_alarm",
        "published",
        "reporting",
        "sim_time",
        "slips",
        "snapshot",
        "stopped",
        "waiting",
        "wall0",
    )

    def __init__(self, snapshot: Snapshot) -> None:
        self.inbox: deque[Job] = deque()  # taken by each batch (by the thread in a fast run)
        self.waiting: set[Job] = set()
        self.snapshot = snapshot  # the last one delivered
        self.sim_time = snapshot.time  # the simulation's time at the last batch end delivered
        self.published = snapshot.time  # real time: when the last batch snapshot was taken
        self.failure: BaseException | None = None
        self.stopped = anyio.Event()
        self.news = anyio.Event()  # real time: wakes a quiet world (see RealTimePacing)
        self.alarms: list[tuple[float, anyio.Event]] = []
        self.next_alarm = math.inf  # the earliest alarm: read by the simulation thread
        self.reporting = 0  # waiting jobs with a progress callback: read by it too
        self.calls = 0  # call()s waiting for the model: read by it too
        self.wall0 = 0.0  # wall clock at the start of the run
        self.slips = 0  # real time: times the simulation gave up catching up
        self.busy = 0.0  # wall seconds spent inside batches
        self.handovers = 0  # thread calls that returned to the loop


class ThreadState:
    """What the simulation thread owns during a run: the last batch end's snapshot, the
    acknowledgements it waits for and the alarms it reported (see the fast run)."""

    __slots__ = ("acks", "batch_ticks", "latest", "ticks_left", "woken")

    def __init__(self, snapshot: Snapshot) -> None:
        self.latest = snapshot  # the last batch end's
        self.acks: list[threading.Event] = []  # posts the loop has yet to take
        self.woken: set[anyio.Event] = set()  # alarms reported during this thread call
        self.batch_ticks = 0  # ticks per batch
        self.ticks_left = 0  # ticks left in this batch
