"""``skimesh demo`` as a user runs it: the default kitting mission and the meal mission, each in
its own process (``python -m skimesh demo``), simulated as fast as possible, must exit 0 with
the goal verified in the world model and in the physics, and leave a valid ``.rrd`` holding
the 3-D scene, each robot's skill timeline, the task events, the plan and the world-model
changes. Ctrl-C in the middle aborts the task, stops cleanly with exit code 130 and still
leaves a valid recording.

These are the project's main job (the README's first command): each takes ~15-30 s here.
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
import warnings
from collections import Counter
from collections.abc import Callable
from pathlib import Path

import pytest
import rerun.chunk
from rerun.error_utils import RerunWarning

from meshlink.testing import free_port

pytestmark = [pytest.mark.slow, pytest.mark.sim, pytest.mark.zenoh]

ROOT = Path(__file__).resolve().parents[2]
RERUN = Path(sys.executable).parent / "rerun"


def demo(tmp_path: Path, *args: str, timeout: float = 300) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "skimesh", "demo", "--rrd", str(tmp_path / "run.rrd"), *args],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=timeout,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )


def assert_no_errors(stderr: str) -> None:
    """Nothing went wrong on the way: no traceback, no error logged (warnings may be)."""
    assert "Traceback" not in stderr and " E " not in stderr, stderr[-3000:]


def verify_rrd(path: Path) -> None:
    """``rerun rrd verify``: the viewer's own loader reads the file without error."""
    done = subprocess.run([str(RERUN), "rrd", "verify", str(path)], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr


class Recording:
    """What an ``.rrd`` holds: rows per entity (static ones apart) and the text lines."""

    def __init__(self, path: Path) -> None:
        self.rows: Counter[str] = Counter()
        self.static: set[str] = set()
        self.texts: dict[str, list[str]] = {}
        for chunk in rerun.chunk.RrdReader(path).stream():
            name = str(chunk.entity_path)
            if chunk.is_static:
                self.static.add(name)
                continue
            self.rows[name] += chunk.num_rows
            batch = chunk.to_record_batch()
            for column in ("TextLog:text", "TextDocument:text"):
                if column in batch.schema.names:
                    lines = self.texts.setdefault(name, [])
                    lines += [str(t) for row in batch.column(column).to_pylist() for t in row or []]

    def lines(self, entity: str) -> list[str]:
        return self.texts.get(entity, [])


def check_recording(path: Path, robots: list[str], moving: str, geometry: str) -> Recording:
    assert path.stat().st_size > 100_000
    verify = subprocess.run(
        [str(RERUN), "rrd", "verify", str(path)], capture_output=True, text=True
    )
    assert verify.returncode == 0, verify.stderr
    rec = Recording(path)
    assert geometry in rec.static, "the scene's geometry, once"
    assert rec.rows[moving] > 50, "body poses over time"
    for robot in robots:
        assert rec.rows[f"/robots/{robot}/progress"] > 0
        assert any("started" in line for line in rec.lines(f"/robots/{robot}/skill")), robot
    events = rec.lines("/task/events")
    assert events[0].startswith("task t-") and "succeeded" in events[-1]
    assert any(line.startswith("plan 0:") for line in events)
    assert rec.lines("/task/plan")[0].startswith("# Plan 0")
    assert rec.rows["/task/plan/graph"] >= 2  # nodes and edges
    changes = rec.lines("/world_model/changes")
    assert changes[0].startswith("rev 1 by demo:"), "the scene, in one transaction"
    assert len(changes) > 10
    assert any("GOAL REACHED" in line for line in rec.lines("/demo/log"))
    return rec


@pytest.mark.timeout(420)
def test_the_kitting_demo_fills_both_kits(tmp_path: Path) -> None:
    started = time.monotonic()
    done = demo(tmp_path)  # the README's command: the default scenario, kitting
    took = time.monotonic() - started
    out = done.stdout
    assert done.returncode == 0, out[-3000:] + done.stderr[-3000:]
    assert "[demo] scenario kitting" in out
    assert "== GOAL REACHED" in out
    assert "facts: 4/4 hold in the world model, 4/4 in the physics" in out
    for part, kit in (("Gear-1", "KitBox-1"), ("Bolt-2", "KitBox-2")):
        assert f"{part} lies in {kit}" in out
    assert f"recording: {tmp_path / 'run.rrd'}" in out
    assert "stopped cleanly" in out
    assert_no_errors(done.stderr)
    rec = check_recording(
        tmp_path / "run.rrd", ["r1", "r2"], "/world/r1.forearm", "/world/Gear-1/cylinder"
    )
    assert any("+contain(KitBox-1, " in line for line in rec.lines("/world_model/changes"))
    for agent in ("r1", "r2"):  # each agent's event log, from agents/<agent>/events
        log = rec.lines(f"/agents/{agent}/events")
        assert any(" started" in line for line in log), agent
        assert any(" wrote rev " in line for line in log), agent
    assert took < 240, f"the kitting demo took {took:.0f} s"


@pytest.mark.timeout(420)
def test_the_meal_demo_serves_the_heated_meal(tmp_path: Path) -> None:
    started = time.monotonic()
    done = demo(tmp_path, "--scenario", "meal")
    took = time.monotonic() - started
    out = done.stdout
    assert done.returncode == 0, out[-3000:] + done.stderr[-3000:]
    assert "== GOAL REACHED" in out
    assert "facts: 3/3 hold in the world model, 2/2 in the physics" in out
    assert "MealBox-1 lies in Tray-1" in out and "door closed" in out
    assert "microwave  #" in out and "heat(" in out, "the microwave is an agent of its own"
    assert_no_errors(done.stderr)
    rec = check_recording(
        tmp_path / "run.rrd", ["friend", "Microwave-1"], "/world/MealBox-1", "/world/Tray-1/box"
    )
    assert any("heat" in line for line in rec.lines("/robots/Microwave-1/skill"))
    assert took < 240, f"the meal demo took {took:.0f} s"


@pytest.mark.timeout(240)
def test_ctrl_c_aborts_the_task_and_stops_cleanly(tmp_path: Path) -> None:
    rrd = tmp_path / "run.rrd"
    lines: list[str] = []
    with subprocess.Popen(
        [sys.executable, "-m", "skimesh", "demo", "--rrd", str(rrd)],
        cwd=tmp_path,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    ) as process:
        try:
            assert process.stdout is not None
            for line in process.stdout:
                lines.append(line)
                if " started" in line and "#" in line:  # the first step runs
                    process.send_signal(signal.SIGINT)
                    break
            lines += process.stdout.readlines()
            code = process.wait(timeout=120)
        finally:
            if process.poll() is None:
                process.kill()
    out = "".join(lines)
    assert code == 130, out[-3000:]
    assert "aborting the task: interrupted (Ctrl-C)" in out
    assert "aborted" in out and "FAILED (preempted)" in out, "the runs were stopped"
    assert "== GOAL NOT REACHED" in out and "stopped cleanly" in out
    verify_rrd(rrd)


def _viewer(port: int, save: Path, *urls: str) -> subprocess.Popen[bytes]:
    """A headless rerun "viewer": ``rerun --save`` writes what it receives to ``save`` (its
    own gRPC server bound to 127.0.0.1:``port``; ``urls``: servers to pull from)."""
    return subprocess.Popen(
        [str(RERUN), "--bind", "127.0.0.1", "--port", str(port), "--save", str(save), *urls],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )


def _wait_for(check: Callable[[], bool], what: str, timeout: float = 60.0) -> None:
    deadline = time.monotonic() + timeout
    while not check():
        assert time.monotonic() < deadline, f"timed out waiting for {what}"
        time.sleep(0.05)


def _listening(port: int) -> bool:
    with socket.socket() as s:
        return s.connect_ex(("127.0.0.1", port)) == 0


def _received(path: Path) -> Recording:
    """What a ``rerun --save`` file holds so far (it has no footer until that viewer ends)."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", "RRD file has no footer", RerunWarning)
        return Recording(path)


def _goal_lines(path: Path) -> list[str]:
    if not path.exists() or path.stat().st_size == 0:
        return []
    try:
        return [line for line in _received(path).lines("/demo/log") if "GOAL REACHED" in line]
    except (ValueError, RuntimeError):  # the last chunk is still being written: look again
        return []


@pytest.mark.timeout(300)
def test_the_recording_streams_to_a_viewer_and_is_served_to_a_late_one(tmp_path: Path) -> None:
    """``--rerun-connect URL`` streams the run to a viewer that is up before it starts;
    ``--rerun-serve`` keeps the finished run available to a viewer that connects afterwards
    (until Ctrl-C). Both receive the whole mission, goal included."""
    live, late = tmp_path / "live.rrd", tmp_path / "late.rrd"
    live_port, served_port, late_port = free_port(), free_port(), free_port()
    viewers = [_viewer(live_port, live)]
    try:
        _wait_for(lambda: _listening(live_port), "the live viewer")
        with subprocess.Popen(
            [sys.executable, "-m", "skimesh", "demo", "--rrd", str(tmp_path / "run.rrd"),
             "--rerun-connect", f"rerun+http://127.0.0.1:{live_port}/proxy",
             "--rerun-serve", "--rerun-port", str(served_port)],
            cwd=tmp_path,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
            env={**os.environ, "PYTHONUNBUFFERED": "1"},
        ) as process:  # fmt: skip
            try:
                assert process.stdout is not None
                lines = []
                for line in process.stdout:
                    lines.append(line)
                    if line.startswith("[demo] serving the recording"):
                        break
                out = "".join(lines)
                assert "== GOAL REACHED" in out, out[-3000:]
                assert f"rerun+http://127.0.0.1:{served_port}/proxy" in out
                url = f"rerun+http://127.0.0.1:{served_port}/proxy"
                viewers.append(_viewer(late_port, late, url))
                _wait_for(lambda: bool(_goal_lines(late)), "the late viewer's copy")
                process.send_signal(signal.SIGINT)
                assert process.wait(timeout=60) == 0
            finally:
                if process.poll() is None:
                    process.kill()
        _wait_for(lambda: bool(_goal_lines(live)), "the live viewer's copy")
    finally:
        for viewer in viewers:
            viewer.send_signal(signal.SIGINT)
            try:
                viewer.wait(timeout=10)
            except subprocess.TimeoutExpired:
                viewer.kill()
                viewer.wait()
    for path in (live, late):
        rec = _received(path)
        assert rec.rows["/world/r1.forearm"] > 50, path.name  # the scene over time
        assert "succeeded" in rec.lines("/task/events")[-1], path.name
