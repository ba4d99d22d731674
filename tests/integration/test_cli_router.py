"""``skimesh router`` as an operator runs it: endpoints from the command line or a config file."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import anyio
import pytest

from meshlink import MeshConfig, open_mesh
from meshlink.testing import free_port

from .procs import ROOT, Child

pytestmark = pytest.mark.zenoh


def test_router_listens_on_the_config_files_endpoints(tmp_path: Path) -> None:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    config = tmp_path / "router.json5"
    listen = f'listen: {{ endpoints: ["{endpoint}"] }}'
    config.write_text(
        f'{{ mode: "router", {listen}, scouting: {{ multicast: {{ enabled: false }} }} }}\n'
    )
    router = Child(["-m", "skimesh", "router", "--config", str(config)], name="router")
    try:
        router.wait_stderr("router listening")

        async def connect() -> str:
            async with open_mesh(MeshConfig(connect=(endpoint,))) as mesh:
                return mesh.zid

        assert anyio.run(connect)
    finally:
        assert router.stop() == 0, router.log()


def test_a_missing_config_file_is_a_clear_error(tmp_path: Path) -> None:
    result = subprocess.run(
        [sys.executable, "-m", "skimesh", "router", "--config", str(tmp_path / "nope.json5")],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert result.returncode == 2
    assert "no config file" in result.stderr
    assert "Traceback" not in result.stderr


def test_a_busy_port_is_one_clear_line(tmp_path: Path) -> None:
    import socket

    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        result = subprocess.run(
            [sys.executable, "-m", "skimesh", "router", "--listen", f"tcp/127.0.0.1:{port}"],
            cwd=ROOT,
            capture_output=True,
            text=True,
            timeout=60,
        )
    assert result.returncode == 2
    assert "Address already in use" in result.stderr
    assert "Traceback" not in result.stderr
