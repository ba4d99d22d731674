"""The public surface of meshlink: exports and the error hierarchy."""

from __future__ import annotations

import meshlink
from meshlink import (
    ConfigError,
    InvalidKeyError,
    MeshlinkError,
    NoReplyError,
    RemoteError,
    SessionError,
)


def test_every_name_in_all_exists() -> None:
    for name in meshlink.__all__:
        assert getattr(meshlink, name) is not None, name
    assert sorted(meshlink.__all__) == sorted(set(meshlink.__all__))


def test_every_error_derives_from_the_root() -> None:
    for error in (ConfigError, SessionError, InvalidKeyError, NoReplyError, RemoteError):
        assert issubclass(error, MeshlinkError)
    assert issubclass(ConfigError, ValueError)
    assert issubclass(InvalidKeyError, ValueError)


def test_error_messages_say_what_to_do() -> None:
    no_reply = NoReplyError("skimesh/x/wm/rpc", 2.5)
    assert "'skimesh/x/wm/rpc'" in str(no_reply)
    assert "2.5 s" in str(no_reply)
    assert "ACL" in str(no_reply)
    assert "running" in str(no_reply)
    remote = RemoteError(b"ValueError: bad \xff", "k")
    assert remote.payload == b"ValueError: bad \xff"
    assert "ValueError: bad" in str(remote)
    client = SessionError.cannot_open("client", ["tcp/127.0.0.1:1"], [], "refused")
    assert "tcp/127.0.0.1:1" in str(client)
    assert "skimesh router" in str(client)
    assert client.endpoints == ("tcp/127.0.0.1:1",)
    router = SessionError.cannot_open("router", [], ["tcp/127.0.0.1:2"], "in use")
    assert "tcp/127.0.0.1:2" in str(router)
    assert "--listen" in str(router)


def test_no_reply_says_the_time_really_waited() -> None:
    early = NoReplyError("skimesh/x/agents/r9/rpc", 600.0, waited=0.4)
    assert "after 0.4 s" in str(early) and "600" not in str(early)
    assert early.waited == 0.4 and early.when in str(early)
    full = NoReplyError("skimesh/x/agents/r9/rpc", 5.0, waited=5.01)
    assert "within 5 s" in str(full)
