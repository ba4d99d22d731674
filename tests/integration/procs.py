"""Child processes for integration tests: start, read JSON/text lines with deadlines, stop by PID.

Each child is started by the test and ended by the test (SIGTERM, then SIGKILL after a grace
period), always by its own PID.
"""

from __future__ import annotations

import json
import os
import queue
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[2]
WORKER = Path(__file__).with_name("wm_worker.py")


class Child:
    """A child process whose stdout and stderr lines are read by background threads."""

    def __init__(
        self, args: Sequence[str], *, name: str, env: dict[str, str] | None = None
    ) -> None:
        self.name = name
        env = dict(env or os.environ, PYTHONUNBUFFERED="1")
        self.proc = subprocess.Popen(
            [sys.executable, *args],
            cwd=ROOT,
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env=env,
        )
        self.stdout: queue.Queue[str | None] = queue.Queue()
        self.stderr_lines: list[str] = []
        self._stderr_event = threading.Condition()
        self._threads = [
            threading.Thread(target=self._pump_stdout, daemon=True),
            threading.Thread(target=self._pump_stderr, daemon=True),
        ]
        for thread in self._threads:
            thread.start()

    @property
    def pid(self) -> int:
        return self.proc.pid

    def _pump_stdout(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self.stdout.put(line)
        self.stdout.put(None)

    def _pump_stderr(self) -> None:
        assert self.proc.stderr is not None
        for line in self.proc.stderr:
            with self._stderr_event:
                self.stderr_lines.append(line)
                self._stderr_event.notify_all()
        with self._stderr_event:
            self.stderr_lines.append("<eof>")
            self._stderr_event.notify_all()

    def wait_stderr(self, needle: str, timeout: float = 30.0) -> str:
        """Block until a stderr line contains ``needle``; fail with the child's log otherwise."""
        deadline = time.monotonic() + timeout
        with self._stderr_event:
            while True:
                for line in self.stderr_lines:
                    if needle in line:
                        return line
                    if line == "<eof>":
                        raise AssertionError(f"{self.name} exited:\n{self.log()}")
                left = deadline - time.monotonic()
                if left <= 0:
                    raise AssertionError(
                        f"{self.name}: no {needle!r} in {timeout} s:\n{self.log()}"
                    )
                self._stderr_event.wait(left)

    def next_json(self, timeout: float = 30.0) -> dict[str, Any] | None:
        """The next stdout line as JSON, or None at end of output."""
        try:
            line = self.stdout.get(timeout=timeout)
        except queue.Empty:
            raise AssertionError(f"{self.name}: no output in {timeout} s:\n{self.log()}") from None
        return None if line is None else dict(json.loads(line))

    def expect(
        self, pred: Callable[[dict[str, Any]], bool], timeout: float = 30.0
    ) -> dict[str, Any]:
        deadline = time.monotonic() + timeout
        while True:
            msg = self.next_json(max(0.1, deadline - time.monotonic()))
            if msg is None:
                raise AssertionError(f"{self.name} ended early:\n{self.log()}")
            if pred(msg):
                return msg

    def send(self, line: str) -> None:
        assert self.proc.stdin is not None
        self.proc.stdin.write(line + "\n")
        self.proc.stdin.flush()

    def close_stdin(self) -> None:
        if self.proc.stdin is not None and not self.proc.stdin.closed:
            self.proc.stdin.close()

    def log(self) -> str:
        return "".join(self.stderr_lines[-40:])

    def kill(self) -> None:
        """SIGKILL, by PID, and reap."""
        if self.proc.poll() is None:
            os.kill(self.proc.pid, signal.SIGKILL)
        self.proc.wait(timeout=10)
        self._reap()

    def _reap(self) -> None:
        """After exit: let the readers hit end of file, then close the pipes."""
        self.close_stdin()
        for thread in self._threads:
            thread.join(timeout=10)
        for stream in (self.proc.stdout, self.proc.stderr):
            if stream is not None:
                stream.close()

    def stop(self, grace: float = 10.0) -> int:
        """SIGTERM, then SIGKILL after ``grace`` seconds; returns the exit code."""
        self.close_stdin()
        if self.proc.poll() is None:
            os.kill(self.proc.pid, signal.SIGTERM)
            try:
                self.proc.wait(timeout=grace)
            except subprocess.TimeoutExpired:
                self.kill()
        code = self.proc.wait()
        self._reap()
        return code


def noop_agent(path: Path, name: str) -> Path:
    """Write the config of an agent ``name`` with a robot of that label, a gripper and the
    ``noop`` skill (``docs/examples/noop.py``) to ``path``; returns ``path``."""
    noop = ROOT / "docs" / "examples" / "noop.py"
    path.write_text(
        f'name = "{name}"\n[robot]\ntype = "Robot"\nlabel = "{name}"\n'
        f'[[devices]]\ntype = "Gripper"\nlabel = "{name}-gripper"\n'
        f'[skills]\npaths = ["{noop}"]\n'
    )
    return path


def start_store(endpoint: str, mesh: str, data_dir: Path) -> Child:
    child = Child(
        ["-m", "skimesh", "wm", "--connect", endpoint, "--mesh", mesh, "--data", str(data_dir)],
        name="store",
    )
    child.wait_stderr("world model ready")
    return child


def start_worker(mode: str, endpoint: str, mesh: str, name: str, count: int) -> Child:
    child = Child(
        [
            str(WORKER),
            mode,
            "--connect",
            endpoint,
            "--mesh",
            mesh,
            "--name",
            name,
            "--count",
            str(count),
        ],
        name=f"worker {name}",
    )
    child.expect(lambda m: "ready" in m)
    return child


def command_imports(argv: Sequence[str], modules: Sequence[str]) -> tuple[int, list[str]]:
    """Run ``skimesh ARGV`` in a fresh interpreter; its exit code and which of ``modules`` it
    imported."""
    probe = (
        "import sys\n"
        "from skimesh.cli import main\n"
        f"code = main({list(argv)!r})\n"
        f"print(code, [m for m in {tuple(modules)!r} if m in sys.modules], file=sys.stderr)"
    )
    done = subprocess.run(
        [sys.executable, "-c", probe], capture_output=True, text=True, timeout=60, cwd=ROOT
    )
    code, loaded = done.stderr.strip().splitlines()[-1].split(" ", 1)
    return int(code), json.loads(loaded.replace("'", '"'))
