"""Where the world model believes each object is, in the recording: a ghost ``belief/<label>``
at the element's world pose (frames chained) with its size, moved when a change moves it (or
the element whose frame it is in), cleared when the element goes, and nothing for an element
the world model does not place."""

from __future__ import annotations

from collections.abc import AsyncIterator
from pathlib import Path

import numpy as np
import pytest
import rerun as rr
import rerun.chunk

from scenario import load_scenario
from scenario.wm import scenario_ops
from skimesh.recording import MissionRecording
from tests.unit.wm_store.stores import memory_client
from wm_store import WmClient
from wm_store.protocol import Orientation, Pose, Position, RemoveElement, UpdateElement
from wm_store.reasoners import SpatialReasoner

ROOT = Path(__file__).resolve().parents[3]


@pytest.fixture
async def wm() -> AsyncIterator[WmClient]:
    async with memory_client() as client:
        yield client


def ghosts(path: Path) -> dict[str, list[tuple[float, np.ndarray | None]]]:
    """Each ghost's centres over ``sim_time`` (None: cleared)."""
    out: dict[str, list[tuple[float, np.ndarray | None]]] = {}
    for chunk in rerun.chunk.RrdReader(str(path)).stream():
        name = str(chunk.entity_path)
        if not name.startswith("/belief/"):
            continue
        batch = chunk.to_record_batch()
        times = batch.column("sim_time").cast("int64").to_pylist()
        if "Boxes3D:centers" in batch.schema.names:
            for t, centers in zip(times, batch.column("Boxes3D:centers").to_pylist(), strict=True):
                if centers is not None:
                    out.setdefault(name, []).append((t / 1e9, np.array(centers[0])))
        elif "Clear:is_recursive" in batch.schema.names:
            out.setdefault(name, []).extend((t / 1e9, None) for t in times)
    return {k: sorted(v, key=lambda e: e[0]) for k, v in out.items()}


@pytest.mark.anyio
async def test_ghosts_follow_the_world_model_not_the_physics(wm: WmClient, tmp_path: Path) -> None:
    scenario = load_scenario(ROOT / "configs" / "scenarios" / "kitting" / "scenario.toml")
    reply = await wm.transact(scenario_ops(scenario))
    ids = {ref[1:]: eid for ref, eid in reply.ids.items() if ref.startswith("$")}
    path = tmp_path / "beliefs.rrd"
    rec = rr.RecordingStream("skimesh-test")
    rec.set_sinks(rr.FileSink(str(path)))
    now = [0.0]
    recording = MissionRecording(rec, sim_clock=lambda: now[0], label_of=str)
    wm.on_change(recording.wm_change)
    recording.follow_beliefs(
        ["Gear-1", "KitBox-1", "Station-1", "Nowhere"], lambda: wm.replica.state
    )
    assert recording.beliefs is not None
    spatial = SpatialReasoner(wm.replica.state)
    placed = {
        label: np.array(spatial.world_transform(ids[label]).translation)
        for label in ("Gear-1", "KitBox-1", "Station-1")
    }

    now[0] = 5.0  # the gear believed in the kit box, 2 cm above its centre
    gear = Pose(Position(0.0, 0.0, 0.02), Orientation(), frame=ids["KitBox-1"])
    await wm.transact([UpdateElement(id=ids["Gear-1"], properties={"pose": gear})])
    now[0] = 7.0  # the kit box believed 0.5 m further along x: the gear in it with it
    box = wm.replica.state.get(ids["KitBox-1"])
    assert box is not None
    old = box.properties["pose"]
    assert isinstance(old, Pose)
    p = old.position
    moved = Pose(Position(p.x + 0.5, p.y, p.z, p.frame), old.orientation, old.frame)
    await wm.transact([UpdateElement(id=ids["KitBox-1"], properties={"pose": moved})])
    now[0] = 9.0  # the gear is gone
    await wm.transact([RemoveElement(id=ids["Gear-1"])])
    assert recording.beliefs.shown == ["KitBox-1", "Station-1"]
    assert set(recording.entities()) >= {"belief/KitBox-1", "belief/Station-1"}
    rec.flush()
    rec.disconnect()

    found = ghosts(path)
    assert set(found) == {"/belief/Gear-1", "/belief/KitBox-1", "/belief/Station-1"}
    station = found["/belief/Station-1"]
    assert len(station) == 1 and station[0][1] == pytest.approx(placed["Station-1"], abs=1e-5)
    (t0, g0), (t1, g1), (t2, g2), (t3, g3) = found["/belief/Gear-1"]
    assert (t0, t1, t2, t3) == (0.0, 5.0, 7.0, 9.0)
    assert g0 == pytest.approx(placed["Gear-1"], abs=1e-5)
    assert g1 == pytest.approx(placed["KitBox-1"] + [0.0, 0.0, 0.02], abs=1e-5)
    assert g2 == pytest.approx(placed["KitBox-1"] + [0.5, 0.0, 0.02], abs=1e-5)
    assert g3 is None  # cleared with the element
    (k0, c0), (k1, c1) = found["/belief/KitBox-1"]
    assert (k0, k1) == (0.0, 7.0)
    assert c0 is not None and c1 is not None
    assert c1 - c0 == pytest.approx([0.5, 0.0, 0.0], abs=1e-5)
