"""What a running skill sees: :class:`RunContext`, the :class:`~skill_agent.SkillContext` of one
run.

It gives the skill its parameters, its elements and device drivers, a world-model view whose
writes are recorded (:class:`~skill_agent.runtime.RunWm`), progress reports, pause
checkpoints and sub-runs; each goes through the :class:`~skill_agent.runtime._run.Run` that
drives it.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, TypeVar

import anyio
import anyio.lowlevel

from skill_agent._errors import ParameterError, ParameterTypeError, RunStateError
from skill_agent.protocol._runs import RunResult
from skill_agent.runtime._run_wm import RunWm
from wm_store import display_name
from wm_store.protocol import Element, Op, Value

if TYPE_CHECKING:
    from skill_agent.runtime._run import Run

__all__ = ["RunContext"]

T = TypeVar("T")


class RunContext:
    """The :class:`~skill_agent.SkillContext` of one run."""

    def __init__(self, run: Run) -> None:
        self._run = run
        self.run_id = run.run_id
        self.agent = run.env.agent
        self.description = run.description
        self.params: Mapping[str, Value] = run.params
        self.simulated = run.simulated
        self.log = logging.getLogger(f"skill_agent.skills.{run.description.name}")
        self._wm = RunWm(run.env.wm, run.wrote)

    @property
    def wm(self) -> RunWm:
        """The agent's world-model client as this run's view: reads as the client, every
        committed write also recorded in the event log (:class:`~skill_agent.runtime.RunWm`)."""
        return self._wm

    def element(self, param: str) -> Element:
        """The element bound to ``param``; raises ParameterError if it is no element id."""
        value = self.params.get(param)
        if not isinstance(value, str):
            raise ParameterError(f"parameter {param!r} of {self.description.name} is no element")
        return self.wm.get_element(value)

    def device(self, param: str, kind: type[T]) -> T:
        """The driver bound to hardware parameter ``param``. Raises RunStateError when
        simulated, ParameterError / ParameterTypeError when there is no such driver."""
        if self.simulated:
            raise RunStateError(f"run {self.run_id} is simulated: no hardware for {param!r}")
        spec = next((p for p in self.description.parameters if p.name == param), None)
        if spec is None or spec.kind != "hardware":
            raise ParameterError(
                f"{param!r} is not a hardware parameter of {self.description.name}"
            )
        device_id = self.params.get(param)
        driver = self._run.env.devices.get(device_id) if isinstance(device_id, str) else None
        name = (
            display_name(self._run.env.wm.find_element(device_id), device_id)
            if isinstance(device_id, str)
            else repr(device_id)
        )
        if driver is None:
            raise ParameterError(f"agent {self.agent} has no driver for device {name}")
        if not isinstance(driver, kind):
            raise ParameterTypeError(
                f"device {name} is a {type(driver).__name__}, not a {kind.__name__}"
            )
        return driver

    async def progress(self, message: str, *, fraction: float = -1.0, step: str = "") -> None:
        """Publish a progress event (also a cancellation point)."""
        await anyio.lowlevel.checkpoint()
        self._run.progress(message, fraction=fraction, step=step)

    async def checkpoint(self) -> None:
        """Hold while this run (or a parent) is paused; a cancellation point otherwise."""
        await self._run.checkpoint()

    async def run_child(self, skill: str, params: Mapping[str, Value]) -> RunResult:
        """Run ``skill`` as a sub-run (composite skills); returns its result. Raises the
        start refusals (UnknownSkillError, ParameterError, ResourceBusyError)."""
        if self._run.env.run_child is None:
            raise RunStateError(f"agent {self.agent} cannot run sub-skills")
        return await self._run.env.run_child(self._run, skill, params)

    async def transact(self, ops: Sequence[Op]) -> int:
        """Commit ``ops`` in one world-model transaction (recorded in the event log, as every
        write through :attr:`wm`); returns its revision."""
        return await self._run.commit(list(ops))
