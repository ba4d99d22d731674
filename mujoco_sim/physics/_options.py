"""The physics options every model of the simulation shares (one place, so attaching a robot,
an arm file or a scene part to a world never raises an option conflict)."""

from __future__ import annotations

import mujoco

__all__ = ["TIMESTEP", "configure_physics"]

TIMESTEP = 0.002
"""Physics step of every model, s."""


def configure_physics(spec: mujoco.MjSpec) -> None:
    """Set the options every model shares: 2 ms step, implicit-fast integrator (implicit servo
    and joint damping), elliptic friction cones with ``impratio`` 10 (grasps slip less),
    radians."""
    spec.compiler.degree = False
    spec.option.timestep = TIMESTEP
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    spec.option.impratio = 10.0
