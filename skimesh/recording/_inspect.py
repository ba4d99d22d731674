"""Reading a finished skimesh ``.rrd``: what it holds, the moment to show, a copy cut there.

:func:`inspect_recording` reads a recording (its application id, its robots, cameras, where
things are, the camera of the layout it was recorded with, and a moment where something
happens: a part in the air, robots moving); :func:`cut_recording` ends a copy of the recording
at a moment, so that ``scripts/screenshot`` can show it with its default layout
(:func:`~skimesh.recording.blueprint` with the recorded camera: the viewer cannot be handed the
layout inside the ``.rrd`` together with a cut copy). :func:`main` is that script's helper,
``python -m skimesh.recording`` (``--help``).
"""

from __future__ import annotations

import argparse
import sys
from collections import defaultdict
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ._blueprint import TIMELINE, blueprint
from ._framing import Eye, Vec, frame
from ._recorded import recorded_eye, recorded_views

__all__ = ["RecordingFacts", "cut_recording", "inspect_recording", "main"]

_LIFTED = 0.03  # m above its first height: a part in a gripper (or falling)
_AWAY = 0.05  # m from where it started: a part that was moved (into a kit, say)
_MOVING = 0.005  # m in _WINDOW seconds: a robot (or appliance) in motion
_WINDOW = 0.5  # s
Track = tuple[Vec, Vec]  # times (s), positions (n x 3)


@dataclass
class RecordingFacts:
    """What :func:`inspect_recording` found in an ``.rrd``."""

    application_id: str
    robots: list[str]
    """Names with a ``robots/<name>/progress`` entity, in order."""
    colors: dict[str, tuple[int, int, int]]
    """A robot's colour in the 3-D view (its arm's), by name."""
    end: float
    """The last ``sim_time`` (s)."""
    moment: float
    """A time (s) when the most is happening: parts in the air, parts moved, robots moving
    (of several such times, the one nearest two thirds of the run)."""
    why: str
    """What happens at ``moment``."""
    bodies: dict[str, Track]
    """Each body's origin over time (a body that never moves: one sample at time 0)."""
    extents: dict[str, tuple[Vec, Vec]]
    """The box around each body's geometry in its own frame (rotations ignored)."""
    eye: Eye | None = None
    """The 3-D camera of the layout sent with the recording (its last), if any."""
    views: dict[str, tuple[str, str]] | None = None
    """The views of the layouts sent with the recording: name -> (kind, origin)."""
    cameras: list[str] | None = None
    """The cameras with images (``cameras/<name>``)."""
    mission: bool = False
    """Whether it records a mission (``task/...``: ``skimesh demo``), not the world alone."""

    def corners(self, at: float | None = None) -> Vec:
        """The corners of the box around each body's geometry (the floor excluded) at time
        ``at``, or wherever the body was over the whole run (n x 3)."""
        none = (np.zeros(3), np.zeros(3))
        out = []
        for body, (t, pos) in self.bodies.items():
            if at is not None:
                i = max(int(np.searchsorted(t, at, side="right")) - 1, 0)
                pos = pos[i : i + 1]
            lo, hi = self.extents.get(body, none)
            lo, hi = pos.min(axis=0) + lo, pos.max(axis=0) + hi
            lo[2] = max(lo[2], 0.0)
            out.append(np.array(np.meshgrid(*zip(lo, hi, strict=True))).T.reshape(-1, 3))
        return np.concatenate(out)


def _seconds(column: Any) -> np.ndarray[Any, Any]:
    import pyarrow as pa  # type: ignore[import-untyped]

    return np.asarray(column.cast(pa.int64()).to_numpy(zero_copy_only=False), dtype=float) / 1e9


def _vectors(batch: Any, column: str) -> np.ndarray[Any, Any]:
    """All values of a list-of-vectors (or list-of-floats) column, as rows."""
    rows = [v for cell in batch.column(column).to_pylist() if cell for v in cell]
    return np.array(rows, dtype=float) if rows else np.zeros((0,))


def _extent(batch: Any, names: list[str]) -> tuple[np.ndarray[Any, Any], np.ndarray[Any, Any]]:
    """The box around the geometry in one chunk, in its body's frame (rotations ignored:
    exact for furniture, close enough for robot links)."""
    lows, highs = [np.zeros(3)], [np.zeros(3)]
    for kind in ("Boxes3D", "Ellipsoids3D"):
        if f"{kind}:half_sizes" in names:
            half = _vectors(batch, f"{kind}:half_sizes")
            center = (
                _vectors(batch, f"{kind}:centers")
                if f"{kind}:centers" in names
                else np.zeros_like(half)
            )
            if len(half) and center.shape == half.shape:
                lows.append((center - half).min(axis=0))
                highs.append((center + half).max(axis=0))
    for kind, origin in (("Cylinders3D", "centers"), ("Capsules3D", "translations")):
        if f"{kind}:lengths" in names and f"{kind}:radii" in names:
            size = _vectors(batch, f"{kind}:lengths").reshape(-1)
            radius = _vectors(batch, f"{kind}:radii").reshape(-1)
            if not len(size) or len(radius) != len(size):
                continue
            at = (
                _vectors(batch, f"{kind}:{origin}")
                if f"{kind}:{origin}" in names
                else np.zeros((len(size), 3))
            )
            if at.shape != (len(size), 3):
                continue
            span = (size + radius)[:, None]
            lows.append((at - span).min(axis=0))
            highs.append((at + span).max(axis=0))
    return np.min(lows, axis=0), np.max(highs, axis=0)


def inspect_recording(path: str | Path) -> RecordingFacts:
    """Read ``path`` (the recording's first store) and sum it up."""
    from rerun.chunk import RrdReader

    reader = RrdReader(str(path))
    recordings = reader.recordings()
    if not recordings:
        raise ValueError(f"{path}: no recording in this file")
    app = str(recordings[0].application_id)
    robots: set[str] = set()
    colors: dict[str, tuple[int, int, int]] = {}
    extent: dict[str, tuple[np.ndarray[Any, Any], np.ndarray[Any, Any]]] = {}
    still: dict[str, np.ndarray[Any, Any]] = {}
    tracks: dict[str, list[tuple[np.ndarray[Any, Any], np.ndarray[Any, Any]]]] = defaultdict(list)
    end = 0.0
    cameras: set[str] = set()
    mission = False
    for chunk in reader.stream(store=recordings[0]):
        parts = str(chunk.entity_path).strip("/").split("/")
        if len(parts) == 3 and parts[0] == "robots" and parts[2] == "progress":
            robots.add(parts[1])
        if len(parts) == 2 and parts[0] == "cameras":
            cameras.add(parts[1])
        mission = mission or parts[0] == "task"
        batch = chunk.to_record_batch()
        names = list(batch.schema.names)
        if TIMELINE in names and not chunk.is_static:
            times = _seconds(batch.column(TIMELINE))
            if len(times):
                end = max(end, float(np.nanmax(times)))
        if parts[0] != "world" or len(parts) < 2 or parts[1] == "world":
            continue  # bodies are world/<body> (world/world: the floor)
        body = parts[1]
        if len(parts) == 3 and chunk.is_static:  # world/<body>/<kind>: its geometry
            lo, hi = _extent(batch, names)
            if body in extent:
                lo, hi = np.minimum(lo, extent[body][0]), np.maximum(hi, extent[body][1])
            extent[body] = (lo, hi)
            robot = body.split(".", 1)[0]  # arm links are capsules named <robot>.<link>
            if parts[2] == "capsule" and robot != body and robot not in colors:
                if "Capsules3D:colors" not in names:
                    continue
                packed = _vectors(batch, "Capsules3D:colors").reshape(-1)
                if len(packed):
                    rgba = int(packed[0])
                    colors[robot] = ((rgba >> 24) & 255, (rgba >> 16) & 255, (rgba >> 8) & 255)
            continue
        if len(parts) != 2 or "Transform3D:translation" not in names:
            continue
        xyz = batch.column("Transform3D:translation").to_pylist()
        rows = [(i, v[0]) for i, v in enumerate(xyz) if v]
        if not rows:
            continue
        pos = np.array([v for _, v in rows], dtype=float)
        if chunk.is_static:
            still[body] = pos[-1:]
        elif TIMELINE in names:
            t = _seconds(batch.column(TIMELINE))[[i for i, _ in rows]]
            tracks[body].append((t, pos))
    bodies: dict[str, Track] = {b: (np.zeros(1), p) for b, p in still.items()}
    for b, pieces in tracks.items():
        t = np.concatenate([t for t, _ in pieces])
        pos = np.concatenate([p for _, p in pieces])
        order = np.argsort(t, kind="stable")
        bodies[b] = (t[order], pos[order])
    if not bodies:
        raise ValueError(f"{path}: no body poses under world/")
    moment, why = _busiest({b: bodies[b] for b in tracks}, end)
    return RecordingFacts(
        application_id=app,
        robots=sorted(robots),
        colors={r: c for r, c in colors.items() if r in robots},
        end=end,
        moment=moment,
        why=why,
        bodies=bodies,
        extents=extent,
        eye=recorded_eye(reader),
        views=recorded_views(reader),
        cameras=sorted(cameras),
        mission=mission,
    )


def _busiest(tracks: dict[str, Track], end: float) -> tuple[float, str]:
    """The busiest time: 2 points per part in the air, 1 per part away from where it started
    (a fuller kit), 1 per robot in motion; of the best times the one nearest two thirds of
    the run. Robot bodies are ``<robot>.<link>`` (the recorder's names), parts are the other
    moving bodies."""
    grid = np.arange(0.0, end + 1e-9, 0.1)
    if len(grid) < 2:
        return end, "a recording without time"
    lifted = np.zeros(len(grid), dtype=int)
    moved = np.zeros(len(grid), dtype=int)
    moving: dict[str, Vec] = {}
    for body, (t, pos) in tracks.items():
        at = np.clip(np.searchsorted(t, grid, side="right") - 1, 0, len(t) - 1)
        before = np.clip(np.searchsorted(t, grid - _WINDOW, side="right") - 1, 0, len(t) - 1)
        known = grid >= t[0]
        if "." in body:
            robot = body.split(".", 1)[0]
            step = np.linalg.norm(pos[at] - pos[before], axis=1) > _MOVING
            moving[robot] = moving.get(robot, np.zeros(len(grid), bool)) | (step & known)
        else:
            lifted += ((pos[at, 2] > pos[0, 2] + _LIFTED) & known).astype(int)
            away = np.linalg.norm(pos[at] - pos[0], axis=1) > _AWAY
            moved += (away & known).astype(int)
    busy = sum((m.astype(int) for m in moving.values()), np.zeros(len(grid), dtype=int))
    score = 2 * lifted + moved + busy
    best = int(score.max())
    if best == 0:
        return float(grid[len(grid) // 2]), "nothing moves: the middle of the run"
    candidates = np.flatnonzero(score == best)
    i = int(candidates[np.argmin(np.abs(grid[candidates] - 2 * end / 3))])
    return float(grid[i]), (
        f"{lifted[i]} part(s) in the air, {moved[i]} moved, {busy[i]} robot(s) moving"
    )


def cut_recording(path: str | Path, moment: float, out: str | Path) -> None:
    """Copy ``path`` to ``out`` without what was logged after ``moment`` (``sim_time``, s):
    static data and data on other timelines only are kept whole. A viewer that follows the
    newest data then shows ``moment``. (``rerun rrd split`` drops static transforms: every
    furniture would stand at the origin.)"""
    import pyarrow as pa
    import pyarrow.compute as pc  # type: ignore[import-untyped]
    from rerun.chunk import Chunk, RrdReader

    limit = round(moment * 1e9)
    reader = RrdReader(str(path))
    entry = reader.recordings()[0]

    def trim(chunk: Chunk) -> list[Chunk]:
        if chunk.is_static or TIMELINE not in chunk.timeline_names:
            return [chunk]
        batch = chunk.to_record_batch()
        times = batch.column(TIMELINE).cast(pa.int64())
        keep = pc.fill_null(pc.less_equal(times, limit), True)
        kept = pc.sum(keep).as_py() or 0
        if kept == batch.num_rows:
            return [chunk]
        if kept == 0:
            return []
        return Chunk.from_record_batch(batch.filter(keep))

    reader.stream(store=entry).flat_map(trim).write_rrd(
        str(out), application_id=str(entry.application_id), recording_id=str(entry.recording_id)
    )


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m skimesh.recording RUN.rrd [--rbl OUT.rbl] [--cut OUT.rrd] [--at S]``: print
    what the recording holds and the moment to show (``moment=<seconds>`` on the last line);
    ``--rbl``: save its default layout (the camera it was recorded with; a recording without
    one: framed on its bodies at the start); ``--cut``: save the recording up to that moment."""
    p = argparse.ArgumentParser(prog="python -m skimesh.recording", description=main.__doc__)
    p.add_argument("rrd", type=Path, help="a skimesh recording")
    p.add_argument("--rbl", type=Path, help="write the blueprint here (.rbl)")
    p.add_argument("--at", type=float, help="show this sim_time (s) instead of the busiest one")
    p.add_argument("--cut", type=Path, help="write the recording up to the moment here (.rrd)")
    args = p.parse_args(argv)
    try:
        facts = inspect_recording(args.rrd)
    except (OSError, ValueError) as e:
        print(f"{p.prog}: {e}", file=sys.stderr)
        return 1
    moment, why = facts.moment, facts.why
    if args.at is not None:
        moment, why = min(max(args.at, 0.0), facts.end), "asked for"
    if args.rbl is not None:
        layout = blueprint(
            robots=facts.robots,
            colors=facts.colors,
            eye=facts.eye or frame(facts.corners(0.0)),
            cameras=facts.cameras or (),
            mission=facts.mission,
        )
        layout.save(facts.application_id, args.rbl)
    if args.cut is not None:
        cut_recording(args.rrd, moment, args.cut)
    print(f"application={facts.application_id}")
    print(f"robots={','.join(facts.robots)}")
    print(f"colors={facts.colors}")
    print(f"cameras={','.join(facts.cameras or [])}")
    print(f"eye={'recorded' if facts.eye else 'framed on the bodies'}")
    print(f"views={'; '.join(sorted(facts.views or {}))}")
    print(f"end={facts.end:.3f}")
    print(f"why={why}")
    print(f"moment={moment:.3f}")
    return 0
