"""Messages of the mesh -> :class:`EventRecord`: :class:`Translator`.

One translator follows a whole site. It ties each skill run to its task (from the task's
``StepStarted``, which names the run), keeps only changes of a run's or a step's state (a
progress report that repeats the last one's state and message is no event), and turns the
periodic device states into transitions (a base starts or stops moving, a gripper takes or
lets go of something, a door opens, heating starts), and words each world-model change against
the elements before it (:class:`~wm_store.ChangeWords`). Its memory is bounded: the tasks of the
newest :data:`RUNS_KEPT` runs, the steps and runs in flight, one state per device, the last
version of each element.
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Callable

import msgspec

from device_drivers.protocol import (
    ApplianceStateReply,
    ArmStateReply,
    BaseStateReply,
    GripperStateReply,
    StateMessage,
)
from skill_agent.protocol import (
    LogEntry,
    ProgressEntry,
    RefusedEntry,
    ResultEntry,
    RunStartedEntry,
    WmWriteEntry,
)
from task_agent.protocol import (
    Planned,
    Replanning,
    SafeState,
    StepFinished,
    StepProgress,
    StepStarted,
    TaskEvent,
    TaskFinished,
    TaskPaused,
    TaskResumed,
    TaskStarted,
)
from wm_store import ChangeWords
from wm_store.protocol import Change

from ._records import EventRecord

__all__ = ["RUNS_KEPT", "Translator"]

RUNS_KEPT = 10_000
"""How many runs' tasks a translator remembers (the newest): entries of a run may arrive
after its task ended, and a run's entries are tied to its task by this map."""

_json = msgspec.json.Encoder()


def _data(message: object) -> str:
    return _json.encode(message).decode()


class Translator:
    """Turns each message into at most one record (see the module doc); no global state."""

    def __init__(self) -> None:
        self._task_of_run: OrderedDict[str, str] = OrderedDict()
        self._runs_of_task: dict[str, dict[int, str]] = {}
        self._last_state: dict[tuple[str, str], tuple[str, str]] = {}
        self._devices: dict[tuple[str, str], tuple[object, ...]] = {}
        self._words = ChangeWords()
        """The last element of each id the world-model changes put (what an update changed)."""
        self.learnt: list[tuple[str, str]] = []
        """(run, task) pairs learnt from ``StepStarted`` and not yet taken by the store: a
        run's own entries may arrive before the step that names it (another publisher)."""

    # ------------------------------------------------------------------ tasks
    def task_event(self, event: TaskEvent) -> EventRecord | None:
        task = event.task_id
        robot = skill = run = outcome = ""
        text = f"task {task}: {type(event).__name__}"  # an event kind newer than this log
        match event:
            case TaskStarted():
                text = f"task {task} started: {event.name or event.goal}"
            case Planned():
                text = (
                    f"task {task} planned: {len(event.steps)} steps by {event.planner or '-'} "
                    f"in {event.plan_seconds:.2f} s, estimated {event.makespan:.1f} s"
                )
            case StepStarted():
                self._task_of_run[event.run_id] = task
                while len(self._task_of_run) > RUNS_KEPT:
                    self._task_of_run.popitem(last=False)
                self._runs_of_task.setdefault(task, {})[event.step] = event.run_id
                self.learnt.append((event.run_id, task))
                robot, skill, run = event.agent, event.skill, event.run_id
                text = f"step {event.step} started: {event.agent} {event.skill}"
            case StepProgress():
                if not self._changed((task, str(event.step)), event.state, event.message):
                    return None
                robot = event.agent
                text = f"step {event.step} {event.state}: {event.message}".rstrip(": ")
            case StepFinished():
                self._last_state.pop((task, str(event.step)), None)
                robot, skill = event.agent, event.skill
                run = self._runs_of_task.get(task, {}).get(event.step, "")
                outcome = "succeeded" if event.success else "failed"
                text = f"step {event.step} {outcome}: {event.agent} {event.skill}"
                if event.message:
                    text += f" ({event.message})"
            case Replanning():
                text = f"task {task} replanning (attempt {event.attempt}): {event.reason}"
            case TaskPaused():
                text = f"task {task} paused ({len(event.runs)} runs held)"
                if event.reason:
                    text += f": {event.reason}"
            case TaskResumed():
                text = f"task {task} resumed ({len(event.runs)} runs)"
            case SafeState():
                robot = event.agent
                held = ", ".join(event.holding)
                text = f"task {task} safe state: {event.agent} held {held}: {event.message}"
            case TaskFinished():
                self._runs_of_task.pop(task, None)
                outcome = event.outcome
                text = f"task {task} {event.outcome} after {event.duration:.1f} s"
                if event.message:
                    text += f": {event.message}"
        return EventRecord(
            stamp=event.stamp,
            kind="task",
            event=type(event).__name__,
            robot=robot,
            task=task,
            skill=skill,
            run=run,
            outcome=outcome,
            text=text,
            data=_data(event),
        )

    # ------------------------------------------------------------------ runs
    def run_entry(self, entry: LogEntry) -> EventRecord | None:
        match entry:
            case RunStartedEntry():
                return self._run(
                    entry,
                    "run_started",
                    entry.agent,
                    entry.run_id,
                    entry.skill,
                    f"{entry.agent} started {entry.skill} ({entry.run_id})"
                    + (" queued" if entry.queued else "")
                    + (" simulated" if entry.simulated else ""),
                )
            case ProgressEntry(progress=p):
                if not self._changed((p.agent, p.run_id), p.state, p.message):
                    return None
                text = f"{p.agent} {p.skill} {p.state}: {p.message}".rstrip(": ")
                return self._run(entry, "progress", p.agent, p.run_id, p.skill, text)
            case ResultEntry(result=r):
                self._last_state.pop((r.agent, r.run_id), None)
                outcome = "succeeded" if r.success else "failed"
                text = f"{r.agent} {r.skill} {outcome} ({r.reason})"
                if r.message:
                    text += f": {r.message}"
                record = self._run(entry, "result", r.agent, r.run_id, r.skill, text, outcome)
                return record
            case RefusedEntry():
                text = f"{entry.agent} refused {entry.skill}: {entry.message}"
                return self._run(
                    entry, "refused", entry.agent, entry.run_id, entry.skill, text, entry.code
                )
            case WmWriteEntry():
                text = f"{entry.agent} wrote revision {entry.revision} ({len(entry.ops)} ops)"
                return self._run(entry, "wm_write", entry.agent, entry.run_id, "", text)

    def task_of(self, run: str) -> str:
        """The task a run (or a sub-run ``<run>.<n>``) belongs to, as far as known."""
        return self._task_of_run.get(run.split(".", 1)[0], "")

    def _run(
        self,
        entry: LogEntry,
        event: str,
        agent: str,
        run: str,
        skill: str,
        text: str,
        outcome: str = "",
    ) -> EventRecord:
        return EventRecord(
            stamp=entry.stamp,
            kind="run",
            event=event,
            robot=agent,
            task=self.task_of(run),
            skill=skill,
            run=run,
            outcome=outcome,
            text=text,
            data=_data(entry),
        )

    def _changed(self, key: tuple[str, str], state: str, message: str) -> bool:
        if self._last_state.get(key) == (state, message):
            return False
        self._last_state[key] = (state, message)
        return True

    # ------------------------------------------------------------------ agents, world model
    @staticmethod
    def liveliness(agent: str, alive: bool, stamp: float) -> EventRecord:
        event = "alive" if alive else "lost"
        return EventRecord(
            stamp=stamp, kind="agent", event=event, robot=agent, text=f"agent {agent} {event}"
        )

    def change(self, change: Change, name_of: Callable[[str], str] | None = None) -> EventRecord:
        """A committed change in words, against the elements the changes before it left
        (learnt from them, in revision order); ``name_of`` names elements not seen yet."""
        return EventRecord(
            stamp=change.stamp,
            kind="wm",
            event="change",
            robot=change.author,
            text=self._words(change, name_of),
            data=_data(change),
        )

    # ------------------------------------------------------------------ devices
    def device_state(
        self, robot: str, device: str, message: StateMessage, stamp: float
    ) -> EventRecord | None:
        """A record when the device's discrete state changed since its last message (the
        first message of a device sets its state without a record)."""
        match message:
            case ArmStateReply(state=s) | BaseStateReply(state=s):
                now: tuple[object, ...] = (s.moving,)
                words = ["moving" if s.moving else "at rest"]
            case GripperStateReply(state=g):
                now = (g.moving, g.holding)
                words = [f"holding {g.holding}" if g.holding else "empty"]
                words.append("moving" if g.moving else "at rest")
            case ApplianceStateReply(state=a):
                now = (a.door_open, a.heating)
                words = ["door open" if a.door_open else "door closed"]
                words.append("heating" if a.heating else "not heating")
        key = (robot, device)
        before = self._devices.get(key)
        self._devices[key] = now
        if before is None or before == now:
            return None
        return EventRecord(
            stamp=stamp,
            kind="device",
            event="state",
            robot=robot,
            text=f"{robot}/{device}: {', '.join(words)}",
            data=_data(message),
        )
