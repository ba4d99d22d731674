"""Wire schema of the ground-truth queryable ``sim/truth`` (msgspec MessagePack; no I/O).

::

    querier -> sim/truth    TruthRequest (tagged by ``request``)
    sim/truth -> querier    TruthReply (tagged by ``reply``) | ErrorReply (a Zenoh error reply)

Every reply carries ``time``, the simulated time (s) at which it was read. Objects and
appliances are named by their labels in the simulation (``Gear-1``, ``KitBox-1``,
``Microwave-1``). Messages only gain fields with defaults.
"""

from __future__ import annotations

from typing import Annotated, TypeAlias

from msgspec import Meta, Struct

from device_drivers._interfaces import ApplianceState, WorldPose
from device_drivers.protocol import ErrorReply
from meshlink.rpc import Decoder

__all__ = [
    "MAX_SETTLE",
    "TRUTH_SCHEMA_VERSION",
    "ApplianceReply",
    "ApplianceTruth",
    "ClockReply",
    "ObjectIn",
    "ObjectInReply",
    "Poses",
    "PosesReply",
    "Scene",
    "SceneReply",
    "Settle",
    "SettleReply",
    "SimClock",
    "TruthReply",
    "TruthRequest",
    "decode_truth_reply",
    "decode_truth_request",
]

TRUTH_SCHEMA_VERSION = 1
MAX_SETTLE = 60.0
"""Longest settling a request may ask for, simulated seconds (each of ``settle`` and
``rest_within``)."""

Label = Annotated[str, Meta(min_length=1, max_length=200)]
SettleSeconds = Annotated[float, Meta(ge=0, le=MAX_SETTLE)]


class _Request(Struct, frozen=True, kw_only=True, tag_field="request"):
    schema_version: int = TRUTH_SCHEMA_VERSION


class SimClock(_Request, tag="sim_clock", frozen=True, kw_only=True):
    """The simulated time and the world's pacing (``ClockReply``)."""


class Scene(_Request, tag="scene", frozen=True, kw_only=True):
    """The objects and appliances the simulation can tell about (``SceneReply``)."""


class Settle(_Request, tag="settle", frozen=True, kw_only=True):
    """Let the world settle: ``settle`` simulated seconds, then until every one of ``objects``
    is at rest and not held, at most ``rest_within`` simulated seconds more (``SettleReply``).
    A fast world steps meanwhile; a real-time world is waited for."""

    objects: Annotated[list[Label], Meta(max_length=1000)] = []
    settle: SettleSeconds = 0.5
    rest_within: SettleSeconds = 5.0


class ObjectIn(_Request, tag="object_in", frozen=True, kw_only=True):
    """Whether ``thing`` lies in ``holder`` at rest, not held (inside its inner footprint,
    between floor and rim), after settling as :class:`Settle` (none by default)."""

    thing: Label
    holder: Label
    settle: SettleSeconds = 0.0
    rest_within: SettleSeconds = 0.0


class ApplianceTruth(_Request, tag="appliance", frozen=True, kw_only=True):
    """An appliance's state in the physics (door angle, heater): ``ApplianceReply``."""

    label: Label


class Poses(_Request, tag="poses", frozen=True, kw_only=True):
    """World poses of objects (or any body: ``r1/gripper``): ``PosesReply``."""

    labels: Annotated[list[Label], Meta(max_length=1000)]


TruthRequest: TypeAlias = SimClock | Scene | Settle | ObjectIn | ApplianceTruth | Poses


class _Reply(Struct, frozen=True, kw_only=True, tag_field="reply"):
    time: float
    """Simulated time, s, when the answer was read."""
    schema_version: int = TRUTH_SCHEMA_VERSION


class ClockReply(_Reply, tag="clock", frozen=True, kw_only=True):
    fast: bool = False
    """The world steps as fast as it can (else in real time)."""
    failure: str = ""
    """Why the world stopped (empty while it runs)."""


class SceneReply(_Reply, tag="scene", frozen=True, kw_only=True):
    objects: list[str] = []
    appliances: list[str] = []


class SettleReply(_Reply, tag="settled", frozen=True, kw_only=True):
    moving: list[str] = []
    """The objects still moving or held when the bound ran out."""


class ObjectInReply(_Reply, tag="object_in", frozen=True, kw_only=True):
    thing: str
    holder: str
    inside: bool
    """``thing`` lies in ``holder``, at rest and not held."""
    pose: WorldPose
    held: bool = False
    speed: float = 0.0
    at_rest: bool = True


class ApplianceReply(_Reply, tag="appliance", frozen=True, kw_only=True):
    label: str
    state: ApplianceState


class PosesReply(_Reply, tag="poses", frozen=True, kw_only=True):
    poses: dict[str, WorldPose] = {}


TruthReply: TypeAlias = (
    ClockReply | SceneReply | SettleReply | ObjectInReply | ApplianceReply | PosesReply | ErrorReply
)

_request: Decoder[TruthRequest] = Decoder(TruthRequest, what="request")
_reply: Decoder[TruthReply] = Decoder(TruthReply, what="reply")


def decode_truth_request(payload: bytes) -> TruthRequest:
    """Raises :class:`meshlink.rpc.WireError` naming the bad field (or the size)."""
    return _request.decode(payload)


def decode_truth_reply(payload: bytes) -> TruthReply:
    """Raises :class:`meshlink.rpc.WireError` for a payload that is no ``TruthReply``."""
    return _reply.decode(payload)
