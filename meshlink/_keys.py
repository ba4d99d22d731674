"""The skimesh key space: every key expression the project uses, built in one place.

All keys live under ``skimesh/<mesh>``, so several meshes (e.g. parallel tests) can share one
router without seeing each other. Every name put into a key (mesh, agent, run, robot, device,
element and task ids) is one key segment, checked by :func:`check_name`: non-empty, letters,
digits, ``_``, ``.`` and ``-`` only. That keeps ``/ * $ ? #`` and whitespace, which would change
the meaning of a key expression, out of the names.

Pure: no Zenoh import, nothing blocks.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from ._errors import InvalidKeyError

__all__ = ["KeySpace", "check_name"]

ROOT = "skimesh"
_NAME = re.compile(r"[A-Za-z0-9_.\-]+")
_BAD_CHAR = re.compile(r"[^A-Za-z0-9_.\-]")


def check_name(value: str, what: str = "name") -> str:
    """Return ``value`` if it may be used as one key segment.

    Raises:
        InvalidKeyError: ``value`` is empty or holds a character other than letters, digits,
            ``_``, ``.`` and ``-``; the message names the character and its position.
    """
    if not isinstance(value, str):
        raise InvalidKeyError(f"{what} must be a str, not {type(value).__name__}")
    if _NAME.fullmatch(value):
        return value
    if not value:
        raise InvalidKeyError(f"{what} is empty; use letters, digits, '_', '.' or '-'")
    bad = _BAD_CHAR.search(value)
    assert bad is not None  # not a full match and not empty: some character is outside the set
    raise InvalidKeyError(
        f"{what} {value!r} contains {bad.group()!r} at position {bad.start()}; "
        "names may only use letters, digits, '_', '.' and '-'"
    )


@dataclass(frozen=True, slots=True)
class KeySpace:
    """Key expressions of one mesh (prefix ``skimesh/<mesh>``).

    Raises:
        InvalidKeyError: at construction if ``mesh`` is not a valid name, and from every
            builder whose arguments are not valid names.
    """

    mesh: str = "default"

    def __post_init__(self) -> None:
        check_name(self.mesh, "mesh name")

    @property
    def prefix(self) -> str:
        """``skimesh/<mesh>``."""
        return f"{ROOT}/{self.mesh}"

    # ---------------------------------------------------------------- world model
    def wm_rpc(self) -> str:
        """Queryable of the WM store for typed requests, writes included."""
        return f"{self.prefix}/wm/rpc"

    def wm_query(self) -> str:
        """Read-only queryable of the WM store (every request but transactions), so an ACL
        can let readers in without letting them write."""
        return f"{self.prefix}/wm/query"

    def wm_write(self, writer: str) -> str:
        """Queryable of the WM store for the transactions of one writer: the store takes
        ``writer`` as the transaction's author, and a router ACL lets each identity query
        only its own (``wm/write/<writer>``)."""
        return f"{self.prefix}/wm/write/{check_name(writer, 'writer')}"

    def wm_writes(self) -> str:
        """Every writer's transaction queryable (``wm/write/*``), served by the store."""
        return f"{self.prefix}/wm/write/*"

    def writer_of_write_key(self, key: str) -> str:
        """The writer in a key built by :meth:`wm_write`; InvalidKeyError if it is none."""
        head = f"{self.prefix}/wm/write/"
        if not key.startswith(head):
            raise InvalidKeyError(f"{key!r} is not a write key of the form {head}<writer>")
        return check_name(key[len(head) :], "writer")

    def wm_changes(self) -> str:
        """Publication of committed WM transactions."""
        return f"{self.prefix}/wm/changes"

    def wm_element(self, element_id: str) -> str:
        """Storage-style key of one WM element."""
        return f"{self.prefix}/wm/elements/{check_name(element_id, 'element id')}"

    def wm_elements(self) -> str:
        """Every WM element (``wm/elements/**``)."""
        return f"{self.prefix}/wm/elements/**"

    # ---------------------------------------------------------------- agents
    def agent(self, name: str) -> str:
        """Liveliness token of one agent."""
        return f"{self.prefix}/agents/{check_name(name, 'agent name')}"

    def agents(self) -> str:
        """Liveliness tokens of every agent (``agents/*``)."""
        return f"{self.prefix}/agents/*"

    def agent_skills(self, name: str) -> str:
        """Queryable serving one agent's skill descriptions."""
        return f"{self.agent(name)}/skills"

    def agents_skills(self) -> str:
        """The skill queryables of every agent (``agents/*/skills``), for discovery."""
        return f"{self.prefix}/agents/*/skills"

    def agent_rpc(self, name: str) -> str:
        """Queryable of one agent: start / stop / pause / resume / status."""
        return f"{self.agent(name)}/rpc"

    def run_progress(self, agent: str, run: str) -> str:
        """Progress events of one skill run."""
        return f"{self.agent(agent)}/runs/{check_name(run, 'run id')}/progress"

    def runs_progress(self, agent: str) -> str:
        """Progress events of every run of one agent (``runs/*/progress``)."""
        return f"{self.agent(agent)}/runs/*/progress"

    def agent_events(self, name: str) -> str:
        """Publication of one agent's structured event log (runs, progress, results,
        refused starts, world-model writes)."""
        return f"{self.agent(name)}/events"

    def agents_events(self) -> str:
        """The event logs of every agent (``agents/*/events``)."""
        return f"{self.prefix}/agents/*/events"

    def name_of_agent_key(self, key: str) -> str:
        """The agent name in a key built by :meth:`agent` (as delivered by a liveliness
        watch on :meth:`agents`).

        Raises:
            InvalidKeyError: ``key`` is not ``skimesh/<this mesh>/agents/<name>``.
        """
        head = f"{self.prefix}/agents/"
        name = key[len(head) :] if key.startswith(head) else ""
        if not name or "/" in name:
            raise InvalidKeyError(f"{key!r} is not an agent key of the form {head}<name>")
        return check_name(name, "agent name")

    # ---------------------------------------------------------------- devices
    def device_state(self, robot: str, device: str) -> str:
        """State publications of one device of one robot."""
        return f"{self._device(robot, device)}/state"

    def device_cmd(self, robot: str, device: str) -> str:
        """Command endpoint of one device of one robot."""
        return f"{self._device(robot, device)}/cmd"

    def sim_truth(self) -> str:
        """The simulator's ground-truth queryable (``sim/truth``)."""
        return f"{self.prefix}/sim/truth"

    def devices(self) -> str:
        """Every device endpoint (``devices/**``)."""
        return f"{self.prefix}/devices/**"

    def devices_state(self) -> str:
        """The state publications of every device (``devices/*/*/state``)."""
        return f"{self.prefix}/devices/*/*/state"

    def device_of_state_key(self, key: str) -> tuple[str, str]:
        """(robot, device) of a key built by :meth:`device_state`; InvalidKeyError if it is
        none."""
        head = f"{self.prefix}/devices/"
        parts = key.removeprefix(head).split("/")
        if not key.startswith(head) or len(parts) != 3 or parts[2] != "state":
            raise InvalidKeyError(f"{key!r} is not a device state key of the form {head}R/D/state")
        return check_name(parts[0], "robot name"), check_name(parts[1], "device name")

    def _device(self, robot: str, device: str) -> str:
        robot = check_name(robot, "robot name")
        return f"{self.prefix}/devices/{robot}/{check_name(device, 'device name')}"

    # ---------------------------------------------------------------- tasks
    def tasks_rpc(self) -> str:
        """Queryable of the task service."""
        return f"{self.prefix}/tasks/rpc"

    def tasks_query(self) -> str:
        """Read-only queryable of the task service (status, list, history, verify), so an
        ACL can let monitors and viewers read tasks without letting them submit or abort."""
        return f"{self.prefix}/tasks/query"

    def operator_rpc(self) -> str:
        """Queryable of the operator desk (pending requests a person answers)."""
        return f"{self.prefix}/operator/rpc"

    def task_events(self, task: str) -> str:
        """Event stream of one task."""
        return f"{self.prefix}/tasks/{check_name(task, 'task id')}/events"

    def tasks_events(self) -> str:
        """The event streams of every task (``tasks/*/events``)."""
        return f"{self.prefix}/tasks/*/events"

    # ---------------------------------------------------------------- site event log
    def eventlog_rpc(self) -> str:
        """Queryable of the site event log (read-only queries)."""
        return f"{self.prefix}/eventlog/rpc"
