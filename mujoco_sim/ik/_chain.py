"""What the IK solvers share: the joint chain of one robot and how a solver is made for a
scenario robot (:class:`ChainSolver`, the base of :class:`~mujoco_sim.placo_ik.PlacoIK`
and :class:`~mujoco_sim.ik.DlsIK`)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Self

from device_drivers import Pose2D
from mujoco_sim.ik._core import IKOptions
from mujoco_sim.models._robot import build_robot
from scenario import RobotSpec, robot_layout

__all__ = ["ChainSolver"]


class ChainSolver:
    """A solver's chain: ``base_joints`` (moved only for whole-body solves) then
    ``arm_joints``; every internal vector is ordered like :attr:`chain`."""

    name = "ik"

    def __init__(
        self,
        robot: Any,
        *,
        tcp_site: str,
        arm_joints: Sequence[str],
        base_joints: Sequence[str] = (),
        options: IKOptions | None = None,
    ) -> None:
        del robot, tcp_site  # the subclass builds its own model of them
        self.options = options or IKOptions()
        self.arm_joints = tuple(arm_joints)
        self.base_joints = tuple(base_joints)

    @classmethod
    def for_robot(
        cls, spec: RobotSpec, options: IKOptions | None = None, *, at: Pose2D | None = None
    ) -> Self:
        """A solver for a scenario robot, generated or with an MJCF arm (built alone; a mobile
        robot's base joints are world coordinates; a fixed robot is built where it stands,
        ``at`` its pose)."""
        names = robot_layout(spec)
        return cls(
            build_robot(spec, at=at),
            tcp_site=names.tcp_site,
            arm_joints=names.arm_joints,
            base_joints=names.base_joints,
            options=options,
        )

    @property
    def chain(self) -> tuple[str, ...]:
        """Base joints then arm joints: the order of every internal vector."""
        return self.base_joints + self.arm_joints
