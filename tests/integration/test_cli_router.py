"""``skimesh router`` as an operator runs it: endpoints from the command line or a config file,
and routers linked to each other with ``--connect`` (one router per host)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import anyio
import pytest

from meshlink import Liveness, MeshConfig, open_mesh
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


def start_router(*flags: str, name: str) -> Child:
    router = Child(["-m", "skimesh", "router", *flags], name=name)
    try:
        router.wait_stderr("router listening")
    except BaseException:
        router.stop()
        raise
    return router


def test_routers_linked_with_connect_carry_samples_between_their_clients(mesh_name: str) -> None:
    """Router B connects to router A (started second, so B's link retries until A is up); a put
    by a client of B reaches a subscriber that is a client of A."""
    a, b = f"tcp/127.0.0.1:{free_port()}", f"tcp/127.0.0.1:{free_port()}"
    routers = [start_router("--listen", b, "--connect", a, name="router B")]
    try:
        assert f"connecting to {a}" in routers[0].wait_stderr("router listening")
        routers.append(start_router("--listen", a, name="router A"))

        async def exchange() -> bytes:
            async with (
                open_mesh(MeshConfig(connect=(a,), mesh=mesh_name)) as on_a,
                open_mesh(MeshConfig(connect=(b,), mesh=mesh_name)) as on_b,
            ):
                keys = on_a.keys
                async with (
                    on_a.subscribe(keys.devices()) as samples,
                    on_b.watch_liveliness(keys.agents()) as tokens,
                ):
                    with anyio.fail_after(30):
                        # Declared after the subscriber on the same session: once B's client
                        # sees the token, the routers are linked. The subscriber's route may
                        # settle a moment later (under load), so the put is repeated, at most
                        # 10 times a second, until the first sample arrives.
                        with on_a.declare_token(keys.agent("probe")):
                            assert await tokens.receive() == Liveness(keys.agent("probe"), True)

                            async def publish() -> None:
                                while True:
                                    on_b.put(keys.device_state("r1", "arm"), b"across the link")
                                    await anyio.sleep(0.1)

                            async with anyio.create_task_group() as tg:
                                tg.start_soon(publish)
                                sample = await samples.receive()
                                tg.cancel_scope.cancel()
                    assert sample.key == keys.device_state("r1", "arm")
                    return sample.payload

        assert anyio.run(exchange) == b"across the link"
    finally:
        codes = [router.stop() for router in reversed(routers)]
        assert codes == [0] * len(routers), "\n".join(router.log() for router in routers)


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
