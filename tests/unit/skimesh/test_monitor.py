"""The monitor's pieces that need no mesh: its clock, the objects posed from the world
model's beliefs while no simulator answers, the hook for a sensor's images, the command's
sinks."""

from __future__ import annotations

import argparse
from collections.abc import AsyncIterator
from pathlib import Path

import numpy as np
import pytest
import rerun as rr
import rerun.chunk

from mujoco_sim.recording import Mirror, Recorder
from scenario import load_scenario
from scenario.wm import scenario_ops
from skimesh.cli import build_parser
from skimesh.monitor import MeshClock, WorldFeed
from tests.unit.wm_store.stores import memory_client
from wm_store import WmClient
from wm_store.reasoners import SpatialReasoner

ROOT = Path(__file__).resolve().parents[3]
KITTING = ROOT / "configs" / "scenarios" / "kitting" / "scenario.toml"


class Wall:
    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


def test_the_clock_is_the_wall_without_a_simulator_then_follows_its_answers() -> None:
    wall = Wall()
    clock = MeshClock(wall)
    wall.now = 102.0
    assert clock() == pytest.approx(2.0)
    assert not MeshClock(wall).simulated
    clock.observe(50.0)  # a simulator answers: its time from now on
    wall.now = 103.0
    assert clock.simulated and clock() == pytest.approx(51.0)  # real-time pace until measured
    clock.observe(58.0)  # 8 simulated seconds in one wall second: a fast world
    assert clock.pace == pytest.approx(8.0)
    wall.now = 103.5
    assert clock() == pytest.approx(62.0)
    clock.observe(60.0)  # the estimate ran ahead: the timeline waits, never goes back
    assert clock() == pytest.approx(62.0)
    wall.now = 104.0
    assert clock() >= 62.0


@pytest.fixture
async def wm() -> AsyncIterator[WmClient]:
    async with memory_client() as client:
        yield client


@pytest.mark.sim
@pytest.mark.anyio
async def test_without_ground_truth_the_objects_stand_where_the_world_model_believes(
    wm: WmClient,
) -> None:
    scenario = load_scenario(KITTING)
    reply = await wm.transact(scenario_ops(scenario))
    gear = reply.ids["$Gear-1"]
    believed = np.array(SpatialReasoner(wm.replica.state).world_transform(gear).translation)
    mirror = Mirror(scenario)
    recorder = Recorder()
    mirror.start(recorder)
    mirror.data.qpos[:] = 0.0  # anywhere but where it is believed
    feed = WorldFeed(mirror, recorder, MeshClock(), wm=wm)
    feed._from_beliefs(mirror.objects)
    mirror.sample(recorder, 1.0)
    assert feed.source == "beliefs"
    at = np.asarray(mirror.data.xpos[mirror.model.body("Gear-1").id])
    assert at == pytest.approx(believed, abs=1e-6)
    recorder.close()


def test_a_sensor_image_is_logged_where_the_layout_shows_cameras(tmp_path: Path) -> None:
    path = tmp_path / "images.rrd"
    recorder = Recorder(path=path)
    feed = WorldFeed(Mirror.__new__(Mirror), recorder, MeshClock())
    feed.camera_image("r1/wrist_camera", np.zeros((24, 32, 3), dtype=np.uint8))
    recorder.rec.flush()
    recorder.rec.disconnect()
    names = {str(c.entity_path) for c in rerun.chunk.RrdReader(str(path)).stream()}
    assert "/cameras/r1.wrist_camera" in names


def _args(*argv: str) -> argparse.Namespace:
    return build_parser().parse_args(["monitor", *argv])


def test_the_command_records_to_a_file_unless_it_streams(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from skimesh.commands import monitor

    monkeypatch.chdir(tmp_path)
    sinks: list[list[object]] = []
    monkeypatch.setattr(rr.RecordingStream, "set_sinks", lambda self, *s: sinks.append([*s]))
    _, lines = monitor._recorder(_args())
    assert lines == ["recording to monitor.rrd"] and isinstance(sinks[-1][0], rr.FileSink)
    _, lines = monitor._recorder(_args("--connect-viewer"))
    assert lines == [f"streaming to the viewer at {monitor.DEFAULT_VIEWER}"]
    assert [type(s) for s in sinks[-1]] == [rr.GrpcSink]
    _, lines = monitor._recorder(
        _args("--rrd", "x.rrd", "--connect-viewer", "rerun+http://h:1/proxy")
    )
    assert [type(s) for s in sinks[-1]] == [rr.FileSink, rr.GrpcSink]
    assert lines[1].endswith("rerun+http://h:1/proxy")
