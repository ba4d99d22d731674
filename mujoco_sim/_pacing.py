"""How a :class:`~mujoco_sim.SimWorld` paces its batches: in real time or as fast as it can.

The runner asks its pacing, before each batch, how many control ticks to run and whether the
batch takes the queued jobs (:meth:`next_batch`). See the module docs of ``mujoco_sim._world``
and, for fast mode, ``mujoco_sim._fast_run`` for what each mode does with the event loop.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import Protocol

import anyio
import anyio.lowlevel

from mujoco_sim._plant import Plant
from mujoco_sim._runner_state import LoopState

__all__ = ["FastPacing", "Pacing", "RealTimePacing"]


class Pacing(Protocol):
    """When the runner's next batch runs, and how long it is."""

    async def next_batch(self) -> tuple[int, bool]:
        """Wait until the next batch is due; return its ticks and whether it takes the jobs
        queued so far."""
        ...


class FastPacing:
    """Batches back to back, ``max_ticks`` each; the loop gets one checkpoint in between."""

    def __init__(self, max_ticks: int) -> None:
        self.max_ticks = max_ticks

    async def next_batch(self) -> tuple[int, bool]:
        await anyio.lowlevel.checkpoint()
        return self.max_ticks, True


class RealTimePacing:
    """Each batch runs when the wall clock says its ticks are due (up to ``max_ticks``); a
    simulation behind by more than ``slip`` seconds gives up catching up and counts a slip. A
    *quiet* world (nothing moves by command, nothing queued or waiting for the model, no alarm
    near) sleeps until a whole batch is due or until news (:attr:`LoopState.news`) wakes it;
    it then first runs the ticks due by then without the jobs (a catch-up batch), so that the
    news starts at the present tick. The clock is shared with the simulation thread during a
    paced run (:meth:`wait_in_thread`), never at the same time as the loop uses it."""

    def __init__(
        self,
        plant: Plant,
        state: LoopState,
        sim_time: Callable[[], float],
        *,
        max_ticks: int,
        slip: float,
        wall0: float,
    ) -> None:
        self._plant = plant
        self._state = state
        self._sim_time = sim_time  # the world's newest snapshot time
        self.max_ticks = max_ticks
        self._slip = slip
        self._wall0 = wall0  # moves forward at each slip
        self._sim0 = plant.time
        self._catch_up = False  # the next batch is a catch-up batch: it takes no job

    async def next_batch(self) -> tuple[int, bool]:
        tick, max_ticks = self._plant.tick_time, self.max_ticks
        while True:
            now = self._sim_time()
            behind = self._behind(now)
            ticks = min(max_ticks, math.floor(behind / tick + 1e-9))
            quiet = self._quiet(max_ticks * tick, now)
            if ticks < 1 or (quiet and ticks < max_ticks):
                self._catch_up = await self._pause((max_ticks if quiet else 1), behind, quiet)
                continue
            take_jobs = not self._catch_up
            self._catch_up = False
            return ticks, take_jobs

    def wait_in_thread(self, sim_time: float) -> int:
        """Simulation thread, between the batches of a paced run (:mod:`mujoco_sim.
        _paced_run`), the simulation at ``sim_time``: wait until a tick is due and return the
        ticks due (up to ``max_ticks``), or 0 once the world is quiet (:meth:`next_batch`
        then paces it on the loop)."""
        tick, max_ticks = self._plant.tick_time, self.max_ticks
        while not self._quiet(max_ticks * tick, sim_time):
            behind = self._behind(sim_time)
            ticks = min(max_ticks, math.floor(behind / tick + 1e-9))
            if ticks >= 1:
                return ticks
            time.sleep(tick - behind)
        return 0

    def _behind(self, sim_time: float) -> float:
        """Wall seconds the simulation at ``sim_time`` is behind the clock; more than
        ``slip`` counts a slip and moves the clock (it gives up catching up)."""
        behind = (time.perf_counter() - self._wall0) - (sim_time - self._sim0)
        if behind > self._slip:
            self._state.slips += 1
            self._wall0 += behind - self._plant.tick_time
            behind = self._plant.tick_time
        return behind

    def _quiet(self, horizon: float, sim_time: float) -> bool:
        """Between batches (the model is not being stepped): nothing moves by command,
        nothing is queued or waits for the model, and no alarm is due within ``horizon`` s."""
        s = self._state
        if s.inbox or s.calls or s.next_alarm - sim_time <= horizon:
            return False
        return not any(ctrl.active for ctrl in self._plant.controllers.values())

    async def _pause(self, ticks: int, behind: float, quiet: bool) -> bool:
        """Wait until ``ticks`` ticks are due; a quiet world also wakes at news (a command, a
        call, an alarm, a stop). Return whether it woke early with ticks due."""
        wait = ticks * self._plant.tick_time - behind
        if not quiet:
            await anyio.sleep(wait)
            return False
        with anyio.move_on_after(wait) as timer:
            await self._state.news.wait()
        self._state.news = anyio.Event()
        return not timer.cancelled_caught
