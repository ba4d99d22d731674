"""Camera images in the recording: ``skimesh sim --images`` renders the scenario's cameras
headless (EGL) and logs them to the ``.rrd`` beside the scene, and its default layout shows
them (one view per camera) beside the 3-D view and the device events.

The simulator runs as its own process (EGL must be chosen before ``mujoco`` is imported, which
this test process has already done), on a loopback router, for two simulated seconds of the
meal scenario in fast mode. Skipped, saying why, where no EGL renderer can be created.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import rerun

from skimesh.recording import recorded_views

from .procs import ROOT

pytestmark = [pytest.mark.sim, pytest.mark.zenoh, pytest.mark.slow]

SIM_SECONDS = 2.0
RATE_HZ = 2.0  # the recorder's default image rate (simulated time)
UNIFORM_JPEG = 1830  # bytes of a uniform 320 x 240 frame at the recorder's JPEG quality


def _images(path: Path) -> dict[str, list[np.ndarray]]:
    """The decoded frames of every camera entity of a recording, in order."""
    frames: dict[str, list[np.ndarray]] = {}
    for chunk in rerun.chunk.RrdReader(path).stream():
        name = str(chunk.entity_path)
        if not name.startswith("/cameras/") or chunk.is_static:
            continue
        batch = chunk.to_record_batch()
        if "EncodedImage:blob" not in batch.schema.names:
            continue
        for row in batch.column("EncodedImage:blob").to_pylist():
            for blob in row or []:
                frames.setdefault(name, []).append(np.asarray(blob, dtype=np.uint8))
    return frames


def test_sim_records_camera_images(tmp_path: Path, router_endpoint: str) -> None:
    rrd = tmp_path / "sim.rrd"
    argv = [sys.executable, "-m", "skimesh", "sim", "--scenario", "meal", "--fast", "--images"]
    argv += ["--duration", str(SIM_SECONDS), "--rerun", str(rrd), "--connect", router_endpoint]
    argv += ["--mesh", f"images-{os.getpid()}"]
    done = subprocess.run(argv, cwd=ROOT, capture_output=True, text=True, timeout=120)
    if "camera images disabled" in done.stderr:
        pytest.skip(f"no EGL renderer on this machine: {done.stderr.strip().splitlines()[-1]}")
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    frames = _images(rrd)
    # the meal scenario's cameras: Camera-1 over the worktop and the arm's wrist camera
    assert sorted(frames) == ["/cameras/Camera-1", "/cameras/friend.wrist_camera"]
    for camera, shots in frames.items():
        # one frame per 1/RATE_HZ s of simulated time from t = 0 (the renderer may drop a
        # frame when it lags, never add one)
        assert 2 <= len(shots) <= int(SIM_SECONDS * RATE_HZ) + 1, camera
        for jpeg in shots:
            assert jpeg[:2].tolist() == [0xFF, 0xD8], "JPEG-compressed frames"
    # a uniform 320 x 240 frame compresses to ~1.8 kB; the worktop scene (microwave, meal box,
    # the arm) to several times that
    assert all(len(jpeg) > 3 * UNIFORM_JPEG for jpeg in frames["/cameras/Camera-1"])
    # the layout: the world, each camera, the device events; no mission, so no plan
    views = recorded_views(rerun.chunk.RrdReader(rrd))
    assert views["Camera-1"] == ("2D", "/cameras/Camera-1")
    assert views["friend/wrist_camera"] == ("2D", "/cameras/friend.wrist_camera")
    assert {"World: physics, labels, world-model beliefs", "Device events"} <= set(views)
    assert not any(name.startswith("Plan") for name in views)
