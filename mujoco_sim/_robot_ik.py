"""Inverse kinematics for the robots of a simulated world (:class:`WorldIK`).

One placo solver and one MuJoCo-native damped-least-squares solver per robot, built with the
world (not lazily: a build takes long enough that the first tool move of a fast world would
lose simulated time; see docs/benchmarks.md, section Simulation). A solve runs on an IK thread
(``anyio.to_thread``) with a limiter per robot, so checking a tool target never stalls
stepping nor the event loop; placo first, DLS if placo fails.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import anyio
import anyio.to_thread

from device_drivers import UnreachableError, WorldPose
from mujoco_sim.ik._core import IKOptions, IKResult, TcpTarget
from mujoco_sim.motion._math import quat_wxyz
from scenario import Scenario

if TYPE_CHECKING:
    from mujoco_sim.ik._dls import DlsIK
    from mujoco_sim.placo_ik._solver import PlacoIK

__all__ = ["WorldIK"]

# 12 restarts, not 24: an unreachable target costs GIL-bound Python time per restart, which
# the event loop feels (see docs/benchmarks.md, section Simulation)
_OPTIONS = IKOptions(position_tolerance=2e-4, orientation_tolerance=2e-3, restarts=12)


class WorldIK:
    """The solvers of every robot of ``scenario`` (blocking to build: see module doc)."""

    def __init__(self, scenario: Scenario) -> None:
        from mujoco_sim.ik._dls import DlsIK
        from mujoco_sim.placo_ik._solver import PlacoIK

        self._solvers: dict[str, tuple[PlacoIK, DlsIK]] = {}
        for robot in scenario.robots:
            spec = robot.spec
            at = robot.pose if spec.fixed else None  # a fixed robot's base frame is its pose
            self._solvers[robot.name] = (
                PlacoIK.for_robot(spec, _OPTIONS, at=at),
                DlsIK.for_robot(spec, _OPTIONS, at=at),
            )
        self._limiters = {r.name: anyio.CapacityLimiter(1) for r in scenario.robots}

    async def solve(
        self, robot: str, q0: dict[str, float], target: WorldPose, *, whole_body: bool
    ) -> IKResult:
        """Joint values putting ``robot``'s tool at ``target``, starting from ``q0``.

        Raises:
            UnreachableError: neither solver converged (the smaller residual is reported).
        """
        w, x, y, z = (float(v) for v in quat_wxyz(target))
        goal = TcpTarget(position=(target.x, target.y, target.z), quat=(w, x, y, z))
        return await anyio.to_thread.run_sync(
            self._solve, robot, q0, goal, whole_body, limiter=self._limiters[robot]
        )

    def _solve(self, robot: str, q0: dict[str, float], goal: TcpTarget, whole: bool) -> IKResult:
        placo, dls = self._solvers[robot]
        try:
            return placo.solve(q0, goal, whole_body=whole)
        except UnreachableError as first:
            try:
                return dls.solve(q0, goal, whole_body=whole)
            except UnreachableError as second:
                raise min(first, second, key=lambda e: e.position_error) from None
