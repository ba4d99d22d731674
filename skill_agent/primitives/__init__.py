"""Motion primitives of the standard skill library: small async building blocks over the
device interfaces (``device_drivers``), plus grasp planning.

Every motion primitive is cancellable (cancellation stops the device, then propagates),
reports progress (fraction 0..1) through an optional callback, and fails with the device
layer's typed errors (:mod:`device_drivers`): ``CollisionError``, ``MotionTimeoutError``
and ``GraspLostError`` (each a ``MotionError``), and ``UnreachableError``,
which derives from :class:`~device_drivers.IKError`, *not* from ``MotionError``
(the IK check raises it before anything moves; a straight move that meets it part-way is held
by the driver). Catch :class:`~device_drivers.DeviceError` for both kinds. Frames:
world; units: SI.

=====================  =======================================================================
module                 contents
=====================  =======================================================================
``_supervise``         the deadline / cancellation / safe-stop wrapper every primitive uses
``_arm``               move_joints, move_to, move_cartesian, approach, retreat, look_at
``_gripper``           open_gripper, close_gripper (returns whether something is held), release
``_base``              navigate_to, face, drive (a velocity)
``_grasp``             plan_grasp (graspPose / graspWidth or top-down), release_pose, free_spot,
                       free_spots (in a container), surface_spots (on a surface)
``poses``              quaternion and pose helpers shared with the world model's reasoner
                       (a public module: scenario building uses it too)
=====================  =======================================================================
"""

from ._arm import approach as approach
from ._arm import look_at as look_at
from ._arm import move_cartesian as move_cartesian
from ._arm import move_joints as move_joints
from ._arm import move_to as move_to
from ._arm import retreat as retreat
from ._base import drive as drive
from ._base import face as face
from ._base import navigate_to as navigate_to
from ._grasp import Grasp as Grasp
from ._grasp import GripperGeometry as GripperGeometry
from ._grasp import NoGraspError as NoGraspError
from ._grasp import extents as extents
from ._grasp import footprint_radius as footprint_radius
from ._grasp import free_spot as free_spot
from ._grasp import free_spots as free_spots
from ._grasp import plan_grasp as plan_grasp
from ._grasp import release_pose as release_pose
from ._grasp import surface_spots as surface_spots
from ._gripper import close_gripper as close_gripper
from ._gripper import open_gripper as open_gripper
from ._gripper import release as release
from ._supervise import STOP_LIMIT as STOP_LIMIT
from ._supervise import halt as halt
from ._supervise import sub_progress as sub_progress
from ._supervise import supervise as supervise

__all__ = [
    "STOP_LIMIT",
    "Grasp",
    "GripperGeometry",
    "NoGraspError",
    "approach",
    "close_gripper",
    "drive",
    "extents",
    "face",
    "footprint_radius",
    "free_spot",
    "free_spots",
    "halt",
    "look_at",
    "move_cartesian",
    "move_joints",
    "move_to",
    "navigate_to",
    "open_gripper",
    "plan_grasp",
    "release",
    "release_pose",
    "retreat",
    "sub_progress",
    "supervise",
    "surface_spots",
]
