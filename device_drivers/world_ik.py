"""Inverse kinematics for the robots of a simulated world (:class:`WorldIK`).

One placo solver and one MuJoCo-native damped-least-squares solver per robot, built with the
world (~20-50 ms each: built lazily, the first tool move of a fast world lost seconds of
simulated time). A solve runs on an IK thread (``anyio.to_thread``) with a limiter per robot,
so checking a tool target never stalls stepping nor the event loop; placo first, DLS if placo
fails.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import anyio
import anyio.to_thread

from device_drivers.errors import UnreachableError
from device_drivers.ik import IKOptions, IKResult, TcpTarget
from device_drivers.interfaces import WorldPose
from device_drivers.motion_math import quat_wxyz
from device_drivers.scenario import Scenario

if TYPE_CHECKING:
    from device_drivers.ik_dls import DlsIK
    from device_drivers.ik_placo import PlacoIK

__all__ = ["WorldIK"]

# 12 restarts, not 24: an unreachable target then costs ~50 ms of GIL-bound Python per solver
# instead of ~0.1 s, which the event loop feels
_OPTIONS = IKOptions(position_tolerance=2e-4, orientation_tolerance=2e-3, restarts=12)


class WorldIK:
    """The solvers of every robot of ``scenario`` (blocking to build: see module doc)."""

    def __init__(self, scenario: Scenario) -> None:
        from device_drivers.ik_dls import DlsIK
        from device_drivers.ik_placo import PlacoIK

        self._solvers: dict[str, tuple[PlacoIK, DlsIK]] = {}
        for robot in scenario.robots:
            spec = robot.spec
            self._solvers[robot.name] = (
                PlacoIK.for_robot(spec, _OPTIONS),
                DlsIK.for_robot(spec, _OPTIONS),
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
