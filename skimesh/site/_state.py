"""A host's site state directory: the lock ``skimesh up`` holds (with its PID), the status
file it keeps current, one log file per process, the store's data.

::

    STATE_DIR/up.lock          locked while `skimesh up` runs; holds its PID
    STATE_DIR/status.json      every component: state, PID, restarts, log (rewritten on change)
    STATE_DIR/logs/NAME.log    each process's stdout and stderr (appended across restarts)
"""

from __future__ import annotations

import fcntl
import json
import os
import signal
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import IO

from ._errors import SiteError

__all__ = ["Row", "StateDir", "Status", "default_state_dir"]


def default_state_dir(site: Path, host: str, configured: str = "") -> Path:
    """The site file's ``state_dir`` (``~`` expanded, ``{host}`` replaced), else
    ``$XDG_STATE_HOME/skimesh/sites/<site file stem>-<host>`` (``~/.local/state/...``)."""
    if configured:
        return Path(configured.replace("{host}", host)).expanduser()
    base = Path(os.environ.get("XDG_STATE_HOME") or Path.home() / ".local" / "state")
    return base / "skimesh" / "sites" / f"{site.stem}-{host}"


@dataclass
class Row:
    """One component as ``skimesh status`` shows it."""

    name: str
    kind: str
    host: str
    state: str
    pid: int | None = None
    restarts: int = 0
    detail: str = ""
    log: str = ""


@dataclass
class Status:
    supervisor: int
    host: str
    site: str
    rows: list[Row] = field(default_factory=list)


class StateDir:
    def __init__(self, path: Path) -> None:
        self.path = path
        self.lock_path = path / "up.lock"
        self.status_path = path / "status.json"
        self.logs = path / "logs"
        self._lock: IO[str] | None = None

    def acquire(self) -> None:
        """Take the lock for this process (SiteError if another `skimesh up` holds it)."""
        self.logs.mkdir(parents=True, exist_ok=True)
        handle = self.lock_path.open("a+", encoding="utf-8")
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            handle.close()
            raise SiteError(
                f"the site is up already here (pid {self.holder()}, state {self.path}); "
                "`skimesh down` stops it"
            ) from None
        handle.truncate(0)
        handle.write(f"{os.getpid()}\n")
        handle.flush()
        self._lock = handle

    def release(self) -> None:
        if self._lock is not None:
            self._lock.close()
            self._lock = None

    def holder(self) -> int | None:
        """The PID of the `skimesh up` holding the lock, or None when none does."""
        if not self.lock_path.exists():
            return None
        with self.lock_path.open("r", encoding="utf-8") as handle:
            try:
                fcntl.flock(handle, fcntl.LOCK_SH | fcntl.LOCK_NB)
            except BlockingIOError:
                text = handle.read().strip()
                return int(text) if text.isdigit() else None
            fcntl.flock(handle, fcntl.LOCK_UN)
            return None

    def write_status(self, status: Status) -> None:
        tmp = self.status_path.with_suffix(".tmp")
        data = {**asdict(status), "rows": [asdict(r) for r in status.rows]}
        tmp.write_text(json.dumps(data, indent=1) + "\n", encoding="utf-8")
        tmp.replace(self.status_path)

    def read_status(self) -> Status | None:
        try:
            data = json.loads(self.status_path.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            return None
        rows = [Row(**r) for r in data.pop("rows", [])]
        return Status(**data, rows=rows)

    def stop_leftovers(self, grace: float) -> list[str]:
        """Stop the processes a `skimesh up` that was killed (SIGKILL) left running, by the
        PIDs of its status file, in reverse order: SIGTERM, SIGKILL after ``grace`` seconds.
        Only PIDs that still run ``python -m skimesh`` are touched. Returns what was stopped."""
        status = self.read_status()
        stopped = []
        for row in reversed(status.rows if status else []):
            if not row.pid or not row.log or row.state in ("stopped", "exited", "failed"):
                continue
            if not _runs_skimesh(row.pid):
                continue
            os.kill(row.pid, signal.SIGTERM)
            deadline = time.monotonic() + grace
            while _runs_skimesh(row.pid) and time.monotonic() < deadline:
                time.sleep(0.05)
            if _runs_skimesh(row.pid):
                os.kill(row.pid, signal.SIGKILL)
            stopped.append(f"{row.name} (pid {row.pid})")
        return stopped

    def log_path(self, name: str) -> Path:
        return self.logs / f"{name}.log"


def _runs_skimesh(pid: int) -> bool:
    """Whether ``pid`` is a live ``python -m skimesh`` process (not a reused PID, nor a
    zombie)."""
    try:
        cmdline = Path(f"/proc/{pid}/cmdline").read_bytes().split(b"\0")
        state = Path(f"/proc/{pid}/stat").read_text(encoding="ascii").rsplit(")", 1)[1].split()
    except (OSError, IndexError):
        return False
    return state[0] != "Z" and b"skimesh" in cmdline and b"-m" in cmdline
