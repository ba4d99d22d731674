"""Motion primitives of the standard skill library: small async building blocks over the
device interfaces (``device_drivers.interfaces``), plus grasp planning.

Every motion primitive is cancellable (cancellation stops the device, then propagates),
reports progress (fraction 0..1) through an optional callback, and fails with the device
layer's typed errors, re-exported here: :class:`CollisionError`, :class:`MotionTimeoutError`
and :class:`GraspLostError` (each a :class:`MotionError`), and :class:`UnreachableError`,
which derives from :class:`~device_drivers.errors.IKError`, *not* from :class:`MotionError`
(the IK check raises it before anything moves; a straight move that meets it part-way is held
by the driver). Catch :class:`~device_drivers.errors.DeviceError` for both kinds. Frames:
world; units: SI.

=====================  =======================================================================
module                 contents
=====================  =======================================================================
``supervise``          the deadline / cancellation / safe-stop wrapper every primitive uses
``arm``                move_joints, move_to, move_cartesian, approach, retreat, look_at
``gripper``            open_gripper, close_gripper (returns whether something is held), release
``base``               navigate_to, face, drive (a velocity)
``grasp``              plan_grasp (graspPose / graspWidth or top-down), release_pose, free_spot,
                       free_spots (in a container), surface_spots (on a surface)
``poses``              quaternion and pose helpers shared with the world model's reasoner
=====================  =======================================================================
"""

from device_drivers.errors import CollisionError as CollisionError
from device_drivers.errors import GraspLostError as GraspLostError
from device_drivers.errors import MotionError as MotionError
from device_drivers.errors import MotionTimeoutError as MotionTimeoutError
from device_drivers.errors import UnreachableError as UnreachableError

from .arm import approach as approach
from .arm import look_at as look_at
from .arm import move_cartesian as move_cartesian
from .arm import move_joints as move_joints
from .arm import move_to as move_to
from .arm import retreat as retreat
from .base import drive as drive
from .base import face as face
from .base import navigate_to as navigate_to
from .grasp import Grasp as Grasp
from .grasp import GripperGeometry as GripperGeometry
from .grasp import NoGraspError as NoGraspError
from .grasp import extents as extents
from .grasp import footprint_radius as footprint_radius
from .grasp import free_spot as free_spot
from .grasp import free_spots as free_spots
from .grasp import plan_grasp as plan_grasp
from .grasp import release_pose as release_pose
from .grasp import surface_spots as surface_spots
from .gripper import close_gripper as close_gripper
from .gripper import open_gripper as open_gripper
from .gripper import release as release
from .supervise import STOP_LIMIT as STOP_LIMIT
from .supervise import halt as halt
from .supervise import sub_progress as sub_progress
from .supervise import supervise as supervise

__all__ = [
    "STOP_LIMIT",
    "CollisionError",
    "Grasp",
    "GraspLostError",
    "GripperGeometry",
    "MotionError",
    "MotionTimeoutError",
    "NoGraspError",
    "UnreachableError",
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
