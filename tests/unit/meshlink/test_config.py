"""MeshConfig validation, its translation to a Zenoh config, and the command-line flags."""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import msgspec
import pytest
import zenoh

from meshlink import (
    DEFAULT_ROUTER_ENDPOINT,
    ConfigError,
    MeshConfig,
    add_mesh_arguments,
    mesh_config_from_args,
    router_config,
    to_zenoh_config,
)


def get(zc: zenoh.Config, key: str) -> Any:
    return json.loads(zc.get_json(key))


def test_defaults_are_a_loopback_client_without_multicast() -> None:
    cfg = MeshConfig()
    assert (cfg.mode, cfg.connect, cfg.listen, cfg.mesh) == ("client", (), (), "default")
    zc = to_zenoh_config(cfg)
    assert get(zc, "mode") == "client"
    assert get(zc, "connect/endpoints") == [DEFAULT_ROUTER_ENDPOINT]
    assert get(zc, "listen/endpoints") == []
    assert get(zc, "scouting/multicast/enabled") is False
    assert get(zc, "scouting/delay") == 0
    assert get(zc, "transport/link/tx/lease") == 10000  # Zenoh's default is left alone
    assert get(zc, "timestamping/enabled") is None
    assert get(zc, "transport/shared_memory/enabled") is False


def test_router_listens_on_loopback_7447_by_default() -> None:
    zc = to_zenoh_config(MeshConfig(mode="router"))
    assert get(zc, "listen/endpoints") == [DEFAULT_ROUTER_ENDPOINT]
    assert get(zc, "connect/endpoints") == []
    assert router_config().listen == (DEFAULT_ROUTER_ENDPOINT,)


def test_peer_listens_on_a_random_loopback_port_and_connects_nowhere() -> None:
    zc = to_zenoh_config(MeshConfig(mode="peer"))
    assert get(zc, "listen/endpoints") == ["tcp/127.0.0.1:0"]
    assert get(zc, "connect/endpoints") == []


def test_fields_override_defaults() -> None:
    cfg = MeshConfig(
        mode="peer",
        connect=("tcp/10.0.0.1:7447", "tcp/[::1]:7448"),
        listen=("tcp/127.0.0.1:7500",),
        multicast_scouting=True,
        lease_ms=2000,
        timestamping=True,
        shared_memory=True,
    )
    zc = to_zenoh_config(cfg)
    assert get(zc, "mode") == "peer"
    assert get(zc, "connect/endpoints") == ["tcp/10.0.0.1:7447", "tcp/[::1]:7448"]
    assert get(zc, "listen/endpoints") == ["tcp/127.0.0.1:7500"]
    assert get(zc, "scouting/multicast/enabled") is True
    assert get(zc, "scouting/delay") is None  # scouting on: Zenoh's delay is kept
    assert get(zc, "transport/link/tx/lease") == 2000
    assert get(zc, "timestamping/enabled") is True
    assert get(zc, "transport/shared_memory/enabled") is True


@pytest.mark.parametrize(
    "endpoint",
    [
        "nonsense",
        "tcp/",
        "tcp/127.0.0.1",
        "tcp/127.0.0.1:99999",
        "tcp/127.0.0.1:0",  # port 0 cannot be connected to
        "foo/127.0.0.1:7447",
        "tcp/127.0.0.1:7447 ",
        " tcp/127.0.0.1:7447",
        "tcp/host name:7447",
        "",
    ],
)
def test_bad_connect_endpoints_are_rejected_with_the_expected_form(endpoint: str) -> None:
    with pytest.raises(ConfigError, match="connect endpoint") as info:
        MeshConfig(connect=(endpoint,))
    assert repr(endpoint) in str(info.value)


@pytest.mark.parametrize(
    "endpoint",
    [
        "tcp/127.0.0.1:7447",
        "tcp/[::1]:7447",
        "tcp/localhost:7447",
        "udp/192.168.1.2:7447",
        "tls/router.example.org:7447?x=1#iface=eth0",
        "quic/127.0.0.1:7447",
        "ws/127.0.0.1:8080",
        "unixsock-stream//tmp/zenoh.sock",
    ],
)
def test_good_endpoints_are_accepted(endpoint: str) -> None:
    assert MeshConfig(connect=(endpoint,)).connect == (endpoint,)


def test_listen_may_use_port_zero_but_not_garbage() -> None:
    assert MeshConfig(mode="peer", listen=("tcp/127.0.0.1:0",)).listen == ("tcp/127.0.0.1:0",)
    with pytest.raises(ConfigError, match="listen endpoint"):
        MeshConfig(listen=("tcp/127.0.0.1:70000",))


@pytest.mark.parametrize(
    ("fields", "message"),
    [
        ({"mode": "server"}, "mode must be one of client, peer, router"),
        ({"mesh": "a/b"}, "contains '/'"),
        ({"mesh": ""}, "mesh name is empty"),
        ({"lease_ms": 0}, "lease_ms must be a positive"),
    ],
)
def test_invalid_fields_raise_config_error(fields: dict[str, Any], message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        MeshConfig(**fields)


def test_decoding_is_strict_about_unknown_fields_and_values() -> None:
    ok = msgspec.json.decode(b'{"mode": "router", "listen": ["tcp/127.0.0.1:1"]}', type=MeshConfig)
    assert ok.listen == ("tcp/127.0.0.1:1",)
    with pytest.raises(msgspec.ValidationError, match="unknown field"):
        msgspec.json.decode(b'{"conect": []}', type=MeshConfig)
    with pytest.raises(msgspec.ValidationError, match="bad connect endpoint"):
        msgspec.json.decode(b'{"connect": ["nope"]}', type=MeshConfig)


def write(path: Path, text: str) -> str:
    path.write_text(text)
    return str(path)


def test_config_file_is_loaded_first_and_fields_override_it(tmp_path: Path) -> None:
    file = write(
        tmp_path / "zenoh.json5",
        """{
          // a site config
          mode: "peer",
          connect: { endpoints: ["tcp/10.1.1.1:7447"] },
          listen: { endpoints: ["tcp/127.0.0.1:7600"] },
          scouting: { multicast: { enabled: true } },
          transport: { link: { tx: { lease: 3000 } } },
        }""",
    )
    kept = to_zenoh_config(MeshConfig(config_file=file))
    assert get(kept, "mode") == "client"  # the field always wins
    assert get(kept, "connect/endpoints") == ["tcp/10.1.1.1:7447"]  # field empty: file kept
    assert get(kept, "listen/endpoints") == ["tcp/127.0.0.1:7600"]
    assert get(kept, "scouting/multicast/enabled") is False  # off unless the field asks
    assert get(kept, "transport/link/tx/lease") == 3000

    overridden = to_zenoh_config(
        MeshConfig(
            config_file=file,
            connect=("tcp/127.0.0.1:9000",),
            listen=("tcp/127.0.0.1:9001",),
            lease_ms=500,
        )
    )
    assert get(overridden, "connect/endpoints") == ["tcp/127.0.0.1:9000"]
    assert get(overridden, "listen/endpoints") == ["tcp/127.0.0.1:9001"]
    assert get(overridden, "transport/link/tx/lease") == 500


def test_missing_or_broken_config_file_raises_config_error(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="does not exist"):
        to_zenoh_config(MeshConfig(config_file=str(tmp_path / "absent.json5")))
    broken = write(tmp_path / "broken.json5", "{ mode: ")
    with pytest.raises(ConfigError, match="cannot load Zenoh config file") as info:
        to_zenoh_config(MeshConfig(config_file=broken))
    assert ".rs:" not in str(info.value)  # Rust source locations are stripped


def parse(*argv: str) -> argparse.Namespace:
    parser = argparse.ArgumentParser()
    add_mesh_arguments(parser)
    return parser.parse_args(argv)


def test_flags_round_trip_into_a_mesh_config(tmp_path: Path) -> None:
    assert mesh_config_from_args(parse()) == MeshConfig()
    file = write(tmp_path / "z.json5", "{}")
    cfg = mesh_config_from_args(
        parse(
            "--connect",
            "tcp/10.0.0.1:7447",
            "--connect",
            "tcp/10.0.0.2:7447",
            "--listen",
            "tcp/127.0.0.1:7000",
            "--config",
            file,
            "--mesh",
            "lab",
            "--mode",
            "peer",
        )
    )
    assert cfg == MeshConfig(
        mode="peer",
        connect=("tcp/10.0.0.1:7447", "tcp/10.0.0.2:7447"),
        listen=("tcp/127.0.0.1:7000",),
        config_file=file,
        mesh="lab",
    )


def test_bad_flag_values_fail_clearly() -> None:
    with pytest.raises(ConfigError, match="bad connect endpoint 'localhost'"):
        mesh_config_from_args(parse("--connect", "localhost"))
    with pytest.raises(SystemExit):
        parse("--mode", "server")
