"""Ground truth over the mesh: a simulator answers what really is, on ``sim/truth``.

The world model holds what the skills wrote; a simulator knows where the objects really are.
``skimesh sim`` serves :class:`GroundTruth` (``mujoco_sim.SimTruth``) with :func:`serve_truth`;
the task agent asks it through :class:`TruthClient` after a task succeeds, to check each goal
fact in the physics. This module loads no simulator.

Requests (:data:`TruthRequest`, tagged by ``request``): :class:`SimClock` (simulated time and
pacing), :class:`Scene` (the objects and appliances it can tell about), :class:`Settle` (let the
world settle: simulated seconds, then until the objects named are at rest, within a bound),
:class:`ObjectIn` (``thing`` lies in ``holder`` at rest and not held, optionally after
settling), :class:`ApplianceTruth` (door and heater state), :class:`Poses` (world poses). Every
reply carries the simulated time it was read at. Errors are
:class:`device_drivers.protocol.ErrorReply`: the standard codes of :mod:`meshlink.rpc` and the
device errors by class name (an unknown label: ``UnknownElementError``).
"""

from __future__ import annotations

from ._messages import MAX_SETTLE as MAX_SETTLE
from ._messages import TRUTH_SCHEMA_VERSION as TRUTH_SCHEMA_VERSION
from ._messages import ApplianceReply as ApplianceReply
from ._messages import ApplianceTruth as ApplianceTruth
from ._messages import ClockReply as ClockReply
from ._messages import ObjectIn as ObjectIn
from ._messages import ObjectInReply as ObjectInReply
from ._messages import Poses as Poses
from ._messages import PosesReply as PosesReply
from ._messages import Scene as Scene
from ._messages import SceneReply as SceneReply
from ._messages import Settle as Settle
from ._messages import SettleReply as SettleReply
from ._messages import SimClock as SimClock
from ._messages import TruthReply as TruthReply
from ._messages import TruthRequest as TruthRequest
from ._messages import decode_truth_reply as decode_truth_reply
from ._messages import decode_truth_request as decode_truth_request
from ._serving import GroundTruth as GroundTruth
from ._serving import TruthClient as TruthClient
from ._serving import serve_truth as serve_truth
from ._serving import truth_handler as truth_handler
from ._serving import truth_key as truth_key

__all__ = [
    "MAX_SETTLE",
    "TRUTH_SCHEMA_VERSION",
    "ApplianceReply",
    "ApplianceTruth",
    "ClockReply",
    "GroundTruth",
    "ObjectIn",
    "ObjectInReply",
    "Poses",
    "PosesReply",
    "Scene",
    "SceneReply",
    "Settle",
    "SettleReply",
    "SimClock",
    "TruthClient",
    "TruthReply",
    "TruthRequest",
    "decode_truth_reply",
    "decode_truth_request",
    "serve_truth",
    "truth_handler",
    "truth_key",
]
