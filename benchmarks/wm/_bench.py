"""The world-model benchmark's plan (counts and durations), constants and run context."""

from __future__ import annotations

import contextlib
import shutil
import sys
import tempfile
import time
import uuid
from pathlib import Path
from typing import Any

import msgspec

from benchmarks.common import (
    Child,
    Row,
)
from meshlink.testing import free_port
from wm_store.durability import DurabilityMode
from wm_store.ontology import Ontology

PAYLOAD = 200  # bytes of the raw baseline payloads (a small change is ~150-250 bytes)
MODES: tuple[DurabilityMode, ...] = ("fsync", "group", "none")
WRITERS = (1, 16, 64)
PART_CLASSES = ("Gear", "Shaft", "Bracket", "Bolt")  # in the core ontology
EXTRA_PART_CLASSES = ("Nut", "Washer", "Spring", "Pin", "Bearing", "Pulley")  # taught at run time


class Plan(msgspec.Struct, frozen=True, kw_only=True):
    """Counts and durations of one run."""

    raw_calls: int
    warmup_calls: int
    tx_warmup: float
    tx_seconds: float
    zenoh_tx_seconds: float
    changes: int
    resolve_calls: int
    sparql_calls: int
    sparql_seconds: float
    rounds: int  # of each tx/s configuration; the best round is reported


FULL = Plan(
    raw_calls=2000,
    warmup_calls=200,
    tx_warmup=0.5,
    tx_seconds=2.0,
    zenoh_tx_seconds=3.0,
    changes=1500,
    resolve_calls=2000,
    sparql_calls=200,
    sparql_seconds=4.0,
    rounds=2,
)
QUICK = Plan(
    raw_calls=500,
    warmup_calls=50,
    tx_warmup=0.2,
    tx_seconds=0.5,
    zenoh_tx_seconds=0.8,
    changes=300,
    resolve_calls=300,
    sparql_calls=20,
    sparql_seconds=0.8,
    rounds=1,
)


def raw_keys(mesh: str) -> tuple[str, str, str]:
    """Keys of the raw get, the raw put and the meshlink (anyio bridge) echo."""
    base = f"skimesh/{mesh}/bench"
    return f"{base}/rtt", f"{base}/oneway", f"{base}/rtt-bridge"


def now_ns() -> int:
    return time.monotonic_ns()


def mass_at(w: int, i: int) -> float:
    return 0.1 + ((w * 7919 + i) % 1000) / 10_000


class Bench:
    """One run: its plan, the children it started, its results."""

    def __init__(self, plan: Plan, data_root: Path, stack: contextlib.ExitStack) -> None:
        self.plan = plan
        self.data_root = data_root
        self.stack = stack
        self.mesh = f"bench-{uuid.uuid4().hex[:10]}"
        self.endpoint = ""
        self.pids: dict[str, int] = {}  # children whose CPU time the tx/s runs account
        self.ontology = Ontology.default()
        self.rows: list[Row] = []
        self.details: dict[str, Any] = {}

    def child(self, role: str, *args: str, ready_timeout: float = 60.0) -> Child:
        child = Child(["-m", "benchmarks.wm", "--role", role, *args], name=role)
        self.stack.callback(child.stop)
        child.expect("ready", timeout=ready_timeout)
        return child

    def temp_dir(self, prefix: str) -> Path:
        path = Path(tempfile.mkdtemp(prefix=prefix, dir=self.data_root))
        self.stack.callback(shutil.rmtree, path, ignore_errors=True)
        return path

    def start_router(self, attempts: int = 5) -> None:
        for attempt in range(attempts):
            endpoint = f"tcp/127.0.0.1:{free_port()}"
            try:
                self.pids["router"] = self.child("router", "--listen", endpoint).pid
            except RuntimeError:  # the port was taken meanwhile
                if attempt == attempts - 1:
                    raise
                continue
            self.endpoint = endpoint
            return

    def mesh_args(self) -> list[str]:
        return ["--connect", self.endpoint, "--mesh", self.mesh]

    def log(self, text: str) -> None:
        print(text, file=sys.stderr, flush=True)


def filesystem_of(path: Path) -> str:
    """``<fstype> on <device>`` of the mount holding ``path`` (Linux /proc/mounts)."""
    best = ("", "?", "?")
    try:
        mounts = Path("/proc/mounts").read_text().splitlines()
    except OSError:
        return "?"
    resolved = str(path.resolve())
    for line in mounts:
        device, mount, fstype, *_ = line.split()
        inside = resolved == mount or resolved.startswith(mount.rstrip("/") + "/")
        if inside and len(mount) >= len(best[0]):
            best = (mount, fstype, device)
    return f"{best[1]} on {best[2]} (mounted at {best[0]})"
