"""The mission in rerun, next to the 3-D scene: task events, the plan, each robot's active skill
and progress, and every world-model change.

The world's :class:`~mujoco_sim.recording.Recorder` records the scene (geometry once, body
poses and joints on the ``sim_time`` timeline); :class:`MissionRecording` logs into the *same*
recording stream, so one ``.rrd`` holds everything. It lives at the application's edge: it
only listens (task events handed to :meth:`task_event`, changes to :meth:`wm_change`, the
agents' event-log entries to :meth:`agent_entry`) and never touches the world model's or the
skills' code. Entities::

    task/events              TextLog: one line per task event (replans WARN, failures ERROR)
    task/plan                TextDocument (markdown): the plan's steps and partial order
    task/plan/graph          GraphNodes + GraphEdges: steps, and "must finish first" edges;
                             one row per agent, its steps left to right in planned order
    robots/<robot>/skill     TextLog: the robot's active skill, its progress messages, results
    robots/<robot>/progress  Scalars: fraction done of its active step (0..1)
    world_model/changes      TextLog: one line per committed transaction (revision, author, what
                             it changed: +Gear-9 [Gear], Gear-1 pose (..) -> (..), removed X)
    belief/<label>           Boxes3D: where the world model believes each object is
                             (:class:`BeliefLayer`, once :meth:`MissionRecording.follow_beliefs`)
    agents/<agent>/events    TextLog: the agent's event log: runs started, results, refused
                             starts, world-model writes (:func:`record_agent_events`)
    demo/log                 TextLog: the demo's own lines (start-up, verification, summary)

Each entry is on two timelines: ``sim_time`` (simulated seconds, the scene's timeline) and
``wall_time`` (seconds since the recording began). A task event is placed at its own time: its
``stamp`` (the task agent's clock) is compared with this host's clock, and an event ``ago``
seconds old lands ``ago`` wall seconds (``ago * pace`` simulated seconds) before now, so the
history of a task joined midway keeps its course (before the recording began: negative times);
a stamp ahead of this host's clock counts as now. Rerun keeps the current time per thread:
everything here is logged from the event loop's thread, the scene from the simulation thread.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable, Mapping

import rerun as rr

from skill_agent import WorldView
from skill_agent.protocol import LogEntry, ParamSpec
from task_agent.discovery import agents_from_view
from task_agent.protocol import (
    Planned,
    PlannedStep,
    Replanning,
    StepFinished,
    StepProgress,
    StepStarted,
    TaskEvent,
    TaskFinished,
    TaskStarted,
)
from wm_store import ChangeWords
from wm_store.protocol import (
    Change,
    Value,
)
from wm_store.scene import SceneState

from ._agents import AgentEventLines
from ._belief import BeliefLayer

__all__ = ["CallText", "MissionRecording", "step_text"]

LabelOf = Callable[[str], str]


def step_text(skill: str, params: Mapping[str, Value], label_of: LabelOf) -> str:
    """``pick(object=Gear-1, holder=PartBox-1)``: element ids shown as their labels."""
    args = ", ".join(f"{k}={label_of(v) if isinstance(v, str) else v}" for k, v in params.items())
    return f"{skill}({args})"


class CallText:
    """A skill call as people read it: ``pick(object=Gear-1, holder=PartBox-1, ...)`` with
    labels for element ids, leaving out the hardware (the robot's own devices), parameters
    left None and configuration parameters at their default. The skills' descriptions come
    from the agents' registrations in the world model (read when first needed)."""

    def __init__(self, view: WorldView, label_of: LabelOf) -> None:
        self.view, self.label_of = view, label_of
        self._specs: dict[tuple[str, str], dict[str, ParamSpec]] = {}

    def _params(self, agent: str, skill: str) -> dict[str, ParamSpec]:
        key = (agent, skill)
        if key not in self._specs:
            for info in agents_from_view(self.view, include_unavailable=True):
                for desc in info.skills:
                    self._specs[(info.name, desc.name)] = {p.name: p for p in desc.parameters}
        return self._specs.get(key, {})

    def __call__(self, agent: str, skill: str, params: Mapping[str, Value]) -> str:
        specs = self._params(agent, skill)

        def shown(name: str, value: Value) -> bool:
            spec = specs.get(name)
            if value is None or spec is None:
                return value is not None
            return spec.kind == "online" or (spec.kind == "offline" and value != spec.default)

        return step_text(skill, {k: v for k, v in params.items() if shown(k, v)}, self.label_of)


class MissionRecording:
    """Logs the mission into ``rec`` (see the module doc). ``sim_clock`` reads the simulated
    time, ``sim_pace`` the simulated seconds per wall second (default: real time), ``clock``
    this host's clock (the task events' stamps are compared with it); ``robots`` maps agent
    names to robot entity names (default: the agent's name)."""

    def __init__(
        self,
        rec: rr.RecordingStream,
        *,
        sim_clock: Callable[[], float],
        label_of: LabelOf,
        call_text: Callable[[str, str, Mapping[str, Value]], str] | None = None,
        robots: Mapping[str, str] | None = None,
        sim_pace: Callable[[], float] = lambda: 1.0,
        clock: Callable[[], float] = time.time,
    ) -> None:
        self.rec = rec
        self.sim_clock, self.sim_pace, self.clock = sim_clock, sim_pace, clock
        self.label_of = label_of
        self.call_text = call_text or (lambda _agent, skill, p: step_text(skill, p, label_of))
        self.robots = dict(robots or {})
        self._t0 = time.monotonic()
        self._steps: dict[tuple[str, int], str] = {}
        self.beliefs: BeliefLayer | None = None
        self._state: Callable[[], SceneState] | None = None
        self._words = ChangeWords()
        """What the changes put (learnt, or known from the replica once :meth:`follow_beliefs`
        gives it): the changes are worded against it (what an update changed)."""
        self.agents = AgentEventLines(
            rec,
            sim_clock=sim_clock,
            wall_clock=lambda: time.monotonic() - self._t0,
            label_of=label_of,
            call_text=self.call_text,
        )
        """The agents' event-log lines (batched: :meth:`AgentEventLines.flush` sends them)."""
        for robot in sorted(set(self.robots.values())):
            rec.log(f"robots/{robot}/progress", rr.SeriesLines(names=["progress"]), static=True)

    def _now(self, ago: float = 0.0) -> None:
        """The current time, or ``ago`` wall seconds before it, on both timelines."""
        self.rec.set_time("sim_time", duration=self.sim_clock() - ago * self.sim_pace())
        self.rec.set_time("wall_time", duration=time.monotonic() - self._t0 - ago)

    def _robot(self, agent: str) -> str:
        return self.robots.get(agent, agent)

    def note(self, text: str, level: str = "INFO") -> None:
        """A line of the demo's own (start-up, verification, summary)."""
        self._now()
        self.rec.log("demo/log", rr.TextLog(text, level=level))

    def wm_change(self, change: Change) -> None:
        """One world-model change (call it from the client's change callback, which runs
        after the replica applied it): its line (what it changed, against the changes before
        it), and the ghosts it moved."""
        self._now()
        self.rec.log("world_model/changes", rr.TextLog(self._words(change, self.label_of)))
        if self.beliefs is not None and self._state is not None:
            self.beliefs.update(self._state())

    def follow_beliefs(self, labels: Iterable[str], state: Callable[[], SceneState]) -> None:
        """From now on, show where the world model (``state()``: the replica's state) believes
        the elements labelled ``labels`` are (:class:`BeliefLayer`); logs them now, then after
        every change :meth:`wm_change` sees. The changes after this are worded against
        ``state()``'s elements (the replica holds the changes :meth:`wm_change` saw)."""
        self.beliefs, self._state = BeliefLayer(self.rec, labels), state
        scene = state()
        self._words.seed(scene.elements.values(), scene.revision)
        self._now()
        self.beliefs.update(state())

    def agent_entry(self, entry: LogEntry) -> None:
        """One entry of an agent's event log (buffered; progress is left out)."""
        self.agents.add(entry)

    def task_event(self, event: TaskEvent) -> None:
        """One task event, at its own time: the task log, the plan, the robot's skill
        timeline."""
        self._now(max(self.clock() - event.stamp, 0.0))
        level, text = "INFO", ""
        match event:
            case TaskStarted():
                text = f"task {event.task_id} started: {event.goal or event.name}"
            case Planned():
                text = self._planned(event)
            case StepStarted():
                self._steps[(event.task_id, event.step)] = event.skill
                call = self.call_text(event.agent, event.skill, event.params)
                text = f"{event.agent}: step {event.step} {call} started"
                self._skill(event.agent, f"step {event.step} {call} started", 0.0)
            case StepProgress():
                skill = self._steps.get((event.task_id, event.step), "")
                message = f"step {event.step} {skill} [{event.state}] {event.message}".rstrip()
                self._skill(event.agent, message, event.fraction if event.fraction >= 0 else None)
                return  # progress goes to the robot's timeline only
            case StepFinished():
                ok = "succeeded" if event.success else f"FAILED ({event.reason}): {event.message}"
                text = f"{event.agent}: step {event.step} {event.skill} {ok}"
                level = "INFO" if event.success else "WARN"
                self._skill(event.agent, f"step {event.step} {event.skill} {ok}", 1.0, level)
            case Replanning():
                text = f"replanning (attempt {event.attempt}): {event.reason}"
                level = "WARN"
            case TaskFinished():
                text = (
                    f"task {event.task_id} {event.outcome}: {event.steps_run} steps run, "
                    f"{event.replans} replans, {event.duration:.1f} s; {event.message}"
                ).rstrip("; ")
                level = "INFO" if event.outcome == "succeeded" else "ERROR"
        self.rec.log("task/events", rr.TextLog(text, level=level))

    def _skill(self, agent: str, text: str, fraction: float | None, level: str = "INFO") -> None:
        robot = self._robot(agent)
        self.rec.log(f"robots/{robot}/skill", rr.TextLog(text, level=level))
        if fraction is not None:
            self.rec.log(f"robots/{robot}/progress", rr.Scalars([fraction]))

    def _planned(self, event: Planned) -> str:
        lines = [
            f"# Plan {event.attempt} ({event.planner}, {event.plan_seconds:.2f} s)",
            "",
            f"{len(event.steps)} steps; estimated makespan {event.makespan:.1f} s "
            f"(sequential {event.sequential:.1f} s)",
            "",
            "| step | agent | skill | after | start | finish |",
            "|---|---|---|---|---|---|",
        ]
        nodes, labels = [], []
        edges: list[tuple[str, str]] = []
        positions = _swimlanes(event)
        for s in sorted(event.steps, key=lambda s: (s.start, s.index)):
            call = self.call_text(s.agent, s.skill, s.params)
            after = ", ".join(map(str, s.after)) or "-"
            lines.append(
                f"| {s.index} | {s.agent} | `{call}` | {after} | {s.start:.1f} | {s.finish:.1f} |"
            )
            nodes.append(str(s.index))
            labels.append(_node_label(s))
            edges += [(str(before), str(s.index)) for before in s.after]
        self.rec.log("task/plan", rr.TextDocument("\n".join(lines), media_type="text/markdown"))
        if nodes:
            where = [positions[int(n)] for n in nodes]
            self.rec.log("task/plan/graph", rr.GraphNodes(nodes, labels=labels, positions=where))
            self.rec.log("task/plan/graph", rr.GraphEdges(edges, graph_type="directed"))
        return (
            f"plan {event.attempt}: {len(event.steps)} steps, estimated makespan "
            f"{event.makespan:.1f} s (sequential {event.sequential:.1f} s), planned in "
            f"{event.plan_seconds:.2f} s"
        )

    def entities(self) -> Iterable[str]:
        """The entity paths this class writes (for checks)."""
        fixed = ["task/events", "task/plan", "world_model/changes", "demo/log"]
        per_robot = [f"robots/{r}/{k}" for r in self.robots.values() for k in ("skill", "progress")]
        ghosts = [] if self.beliefs is None else map(BeliefLayer.entity, self.beliefs.shown)
        return [*fixed, *per_robot, *self.agents.entities(), *ghosts]


# the plan graph's spacing, in graph units: between lanes, per label character, between steps
_ROW, _CHAR, _GAP = 45.0, 7.5, 40.0


def _swimlanes(event: Planned) -> dict[int, tuple[float, float]]:
    """Where each step of a plan is drawn: one row per agent (in order of their first step),
    each agent's steps left to right in the order they are planned to start, as far apart as
    the longest label needs."""
    steps = sorted(event.steps, key=lambda s: (s.start, s.index))
    lanes = list(dict.fromkeys(s.agent for s in steps))
    longest = max((len(_node_label(s)) for s in steps), default=0)
    column = longest * _CHAR + _GAP
    done: dict[str, int] = {}
    out: dict[int, tuple[float, float]] = {}
    for s in steps:
        n = done.get(s.agent, 0)
        done[s.agent] = n + 1
        out[s.index] = (n * column, lanes.index(s.agent) * _ROW)
    return out


def _node_label(step: PlannedStep) -> str:
    return f"{step.index} {step.agent}: {step.skill}"
