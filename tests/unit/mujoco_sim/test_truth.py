"""The simulator's ground truth (``sim/truth``) answered from an in-process world, fast: the
clock, the scene, settling, ``object_in``, appliance states and poses, each with the simulated
time; unknown labels and hostile payloads get typed error replies."""

from __future__ import annotations

from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

import pytest

from device_drivers import protocol as dev
from device_drivers import truth as t
from meshlink.rpc import (
    DEFAULT_MAX_REQUEST_BYTES,
    Decoder,
    ErrorReply,
    WireError,
    encode,
)
from meshlink.testing import check_reply, hostile_payloads
from mujoco_sim import SimTruth, SimWorld, WorldOptions, running_world
from scenario import load_scenario

pytestmark = [pytest.mark.sim, pytest.mark.anyio]

MEAL = Path(__file__).resolve().parents[3] / "configs" / "scenarios" / "meal" / "scenario.toml"
REPLIES: Decoder[Any] = Decoder(t.TruthReply, what="reply")


@pytest.fixture
async def world() -> AsyncIterator[SimWorld]:
    async with running_world(load_scenario(MEAL), WorldOptions(fast=True)) as w:
        yield w


async def ask(truth: SimTruth, request: t.TruthRequest | bytes) -> tuple[object, bool]:
    """One request through the queryable's handler (bytes in, bytes out)."""
    payload = request if isinstance(request, bytes) else encode(request)
    data, ok = await t.truth_handler(truth).handle_bytes(payload)
    return check_reply(data, ok, REPLIES), ok


async def test_every_request_is_answered_with_the_simulated_time(world: SimWorld) -> None:
    truth = SimTruth(world)
    clock, _ = await ask(truth, t.SimClock())
    assert isinstance(clock, t.ClockReply) and clock.fast and not clock.failure
    scene, _ = await ask(truth, t.Scene())
    assert isinstance(scene, t.SceneReply)
    assert {"MealBox-1", "Tray-1"} <= set(scene.objects) and scene.appliances == ["Microwave-1"]
    settled, _ = await ask(truth, t.Settle(objects=["MealBox-1"], settle=0.3, rest_within=2.0))
    assert isinstance(settled, t.SettleReply) and settled.moving == []
    assert settled.time >= clock.time + 0.3, "a fast world steps while it settles"
    inside, _ = await ask(truth, t.ObjectIn(thing="MealBox-1", holder="Tray-1"))
    assert isinstance(inside, t.ObjectInReply)
    assert (inside.inside, inside.at_rest, inside.held) == (False, True, False)
    assert inside.time >= settled.time and inside.pose.z > 0.5  # on the worktop
    oven, _ = await ask(truth, t.ApplianceTruth(label="Microwave-1"))
    assert isinstance(oven, t.ApplianceReply)
    assert not oven.state.door_open and not oven.state.heating
    poses, _ = await ask(truth, t.Poses(labels=["MealBox-1", "Tray-1"]))
    assert isinstance(poses, t.PosesReply) and poses.poses["MealBox-1"] == inside.pose


async def test_unknown_labels_get_typed_errors(world: SimWorld) -> None:
    truth = SimTruth(world)
    cases: list[tuple[t.TruthRequest, str]] = [
        (t.ObjectIn(thing="MealBox-9", holder="Tray-1"), "MealBox-1"),  # a close name
        (t.ObjectIn(thing="MealBox-1", holder="Nowhere"), "Nowhere"),
        (t.Settle(objects=["Nope"]), "Nope"),
        (t.ApplianceTruth(label="Tray-1"), "no appliance named 'Tray-1'"),
        (t.Poses(labels=["Ghost"]), "Ghost"),
    ]
    for request, words in cases:
        reply, ok = await ask(truth, request)
        assert not ok and isinstance(reply, ErrorReply), reply
        assert reply.code == "UnknownElementError" and words in reply.message, reply
        error = dev.error_from_reply(encode(reply))
        assert type(error).__name__ == "UnknownElementError"


def _refusal(requests: Decoder[Any], payload: bytes) -> str | None:
    """The code a payload that is no request must get (``bad_request``, ``too_large``)."""
    try:
        requests.decode(payload)
    except WireError as exc:
        return exc.code
    return None


async def test_hostile_payloads_get_error_replies(world: SimWorld) -> None:
    truth = SimTruth(world)
    samples = (
        encode(t.SimClock()),
        encode(t.ObjectIn(thing="MealBox-1", holder="Tray-1")),
        encode(t.Settle(objects=["MealBox-1"], settle=0.0, rest_within=0.0)),
    )
    out_of_bounds = [
        encode({"request": "settle", "settle": 1e9}),
        encode({"request": "object_in", "thing": "", "holder": "Tray-1"}),
        encode({"request": "poses", "labels": ["x"] * 1001}),
    ]
    requests: Decoder[Any] = Decoder(
        t.TruthRequest, max_bytes=DEFAULT_MAX_REQUEST_BYTES, what="request"
    )
    for payload in [*hostile_payloads(samples), *out_of_bounds]:
        reply, ok = await ask(truth, payload)
        want = _refusal(requests, payload)
        if want is not None:
            assert not ok and isinstance(reply, ErrorReply), payload[:40]
            assert reply.code == want, (payload[:40], reply)
        else:  # a valid request (a mutation may stay one): a reply or a typed error
            assert ok or (isinstance(reply, ErrorReply) and reply.code), reply
    assert world.failure is None
