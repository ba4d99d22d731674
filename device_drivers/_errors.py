"""Errors of the device layer. Every exception raised by ``device_drivers`` derives from
:class:`DeviceError`, so callers can catch the package as a whole.

Hierarchy::

    DeviceError
    ├── ModelError                  a robot or scene model cannot be built, exported or loaded
    │   ├── UnknownElementError     no joint/site/actuator of that name (suggests close names)
    │   └── scenario.ScenarioError  a scenario file is invalid (defined in ``scenario``)
    ├── IKError                     IK cannot be set up or run (unknown frame or joint, bad q0)
    │   └── UnreachableError        the solver did not converge: target out of reach or blocked by
    │                               joint limits; carries the residual errors
    ├── SimulationDivergedError     NaN/Inf or runaway accelerations in the simulation state
    ├── MotionError                 a commanded motion did not complete
    │   ├── CollisionError          the motion would hit, or hit, something
    │   ├── MotionTimeoutError      the motion did not reach its target in time
    │   ├── MotionStoppedError      stop() (or a door opening, a newer halt) ended the motion
    │   └── GraspLostError          the gripper lost (or never got) the object
    ├── CommandError                the command is malformed or not allowed now (nothing moved)
    ├── DeviceBusyError             the device is executing another command
    └── DeviceUnavailableError      the device cannot be reached (remote transport) or is stopped

Messages name the file, body, joint or site concerned and, where known, what to do.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable, Mapping

__all__ = [
    "CollisionError",
    "CommandError",
    "DeviceBusyError",
    "DeviceError",
    "DeviceUnavailableError",
    "GraspLostError",
    "IKError",
    "ModelError",
    "MotionError",
    "MotionStoppedError",
    "MotionTimeoutError",
    "SimulationDivergedError",
    "UnknownElementError",
    "UnreachableError",
]


class DeviceError(Exception):
    """Root of every device-layer error."""


class ModelError(DeviceError):
    """A robot or scene model cannot be built, exported or loaded.

    ``source`` names what failed (a file path, a body or element name, or a robot prefix).
    """

    def __init__(self, message: str, *, source: str | None = None) -> None:
        super().__init__(message if source is None else f"{source}: {message}")
        self.source = source


class UnknownElementError(ModelError):
    """The model has no element of that kind and name; the message suggests close names."""

    def __init__(self, kind: str, name: str, known: Iterable[str]) -> None:
        close = difflib.get_close_matches(name, list(dict.fromkeys(known)), n=3, cutoff=0.6)
        hint = f"; did you mean {', '.join(map(repr, close))}?" if close else ""
        super().__init__(f"no {kind} named {name!r}{hint}")
        self.kind = kind
        self.name = name


class IKError(DeviceError):
    """Inverse kinematics cannot be set up or run (unknown site/joint, malformed target)."""


class UnreachableError(IKError):
    """The IK solver did not reach the target within tolerance.

    Attributes:
        position_error: best distance tcp → target position reached, in metres.
        orientation_error: best orientation error reached, in radians (0 if unconstrained).
        iterations: solver iterations spent over all restarts.
        solver: name of the solver that gave up.
        joints: the best joint configuration found (joint name → rad or m).
    """

    def __init__(
        self,
        *,
        position_error: float,
        orientation_error: float,
        iterations: int,
        solver: str,
        joints: Mapping[str, float],
        whole_body: bool,
    ) -> None:
        hint = (
            "move the base closer or solve with whole_body=True"
            if not whole_body
            else "the target is outside the reachable workspace or against joint limits"
        )
        super().__init__(
            f"{solver}: target not reached after {iterations} iterations: "
            f"position error {position_error * 1000:.2f} mm, "
            f"orientation error {orientation_error:.4f} rad ({hint})"
        )
        self.position_error = position_error
        self.orientation_error = orientation_error
        self.iterations = iterations
        self.solver = solver
        self.joints = dict(joints)
        self.whole_body = whole_body


class SimulationDivergedError(DeviceError):
    """The simulation state holds NaN/Inf values or runaway accelerations.

    Attributes:
        time: simulation time of the bad state, in seconds.
        culprit: the joint or body the bad value belongs to, if it could be identified.
        field: the ``MjData`` field that was bad (``qpos``, ``qvel``, ``qacc``, ...).
    """

    def __init__(self, message: str, *, time: float, culprit: str | None, field: str) -> None:
        where = f" at joint/body {culprit!r}" if culprit else ""
        super().__init__(f"simulation diverged at t={time:.4f} s: {message} in {field}{where}")
        self.time = time
        self.culprit = culprit
        self.field = field


class MotionError(DeviceError):
    """A commanded motion did not complete; the device has stopped safely."""


class CollisionError(MotionError):
    """The motion would hit (or hit) something; names what."""


class MotionTimeoutError(MotionError):
    """The motion did not reach its target within its time limit."""


class MotionStoppedError(MotionError):
    """The motion was ended before its target by :meth:`stop`, a halt after a cancellation,
    or the device's own safety logic (a microwave door opened while heating)."""


class GraspLostError(MotionError):
    """The gripper does not hold the object it should (never grasped, or dropped it)."""


class CommandError(DeviceError):
    """The command is malformed or not allowed in the device's present state (an unknown joint,
    a target outside the joint limits, heating with the door open). Nothing moved."""


class DeviceBusyError(DeviceError):
    """The device is executing another command; stop it first."""


class DeviceUnavailableError(DeviceError):
    """The device cannot be reached (remote transport) or its simulation stopped."""
