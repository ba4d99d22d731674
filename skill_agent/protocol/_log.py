"""The agent's event log on the wire: one tagged entry (tag field ``kind``) per thing its
runtime did, published on ``agents/<agent>/events``.
"""

from __future__ import annotations

from typing import TypeAlias

from msgspec import Struct

from skill_agent.protocol._runs import Progress, RunResult
from skill_agent.protocol._skills import SCHEMA_VERSION
from wm_store.protocol import Op, Value

# --------------------------------------------------------------------------- event log
# One entry per thing the agent's runtime did (``skill_agent.runtime.EventLog``), published on
# ``agents/<agent>/events`` and appended to the agent's JSON-lines file. Tag field ``kind``;
# not frozen: the log stamps an entry when it records it.


class RunStartedEntry(Struct, tag="run_started", tag_field="kind", kw_only=True):
    """A run was accepted (parameters specified, resources locked or queued); ``parent``: the
    run of a composite skill this one is a sub-run of."""

    agent: str
    run_id: str
    skill: str
    params: dict[str, Value] = {}
    inferred: dict[str, str] = {}
    resources: list[str] = []
    simulated: bool = False
    queued: bool = False
    parent: str = ""
    stamp: float = 0.0
    schema_version: int = SCHEMA_VERSION


class ProgressEntry(Struct, tag="progress", tag_field="kind", kw_only=True):
    progress: Progress
    stamp: float = 0.0
    schema_version: int = SCHEMA_VERSION


class ResultEntry(Struct, tag="result", tag_field="kind", kw_only=True):
    result: RunResult
    stamp: float = 0.0
    schema_version: int = SCHEMA_VERSION


class RefusedEntry(Struct, tag="refused", tag_field="kind", kw_only=True):
    """A start request refused before any run existed (or at its pre-condition check)."""

    agent: str
    skill: str
    code: str
    message: str
    run_id: str = ""
    stamp: float = 0.0
    schema_version: int = SCHEMA_VERSION


class WmWriteEntry(Struct, tag="wm_write", tag_field="kind", kw_only=True):
    """A world-model transaction committed for a run: its effects, or a write of its skill
    (through ``ctx.wm``'s write methods or ``ctx.transact``, in any skill method)."""

    agent: str
    run_id: str
    revision: int
    ops: list[Op]
    step: str = ""
    """The run's step when it wrote: ``pre_sense``, ``execute``, ``post_sense``, ``commit``
    (the effects), ``preempt`` (``on_preempt``); "" from an older agent."""
    stamp: float = 0.0
    schema_version: int = SCHEMA_VERSION


LogEntry: TypeAlias = RunStartedEntry | ProgressEntry | ResultEntry | RefusedEntry | WmWriteEntry
