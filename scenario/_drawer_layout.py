"""Where a cabinet's drawer and its handle are (pure numbers, no MuJoCo): shared by the scene
(:mod:`mujoco_sim.models`) and the world model's scenario scene, so they cannot
disagree. Frames and names are those of :mod:`mujoco_sim.models`.
"""

from __future__ import annotations

from typing import NamedTuple

from scenario._schema import CABINET_TOP, DRAWER_CLEARANCE, DrawerSpec, FurnitureEntry

__all__ = ["HANDLE_HALF", "PANEL", "SIDE", "WALL", "DrawerLayout", "drawer_layout"]

HANDLE_HALF = (0.008, 0.07, 0.008)
"""Half sizes of the handle bar (x: thickness a gripper pinches, y: length, z), m."""
WALL = 0.008
"""Drawer wall thickness, m."""
PANEL = 0.02
"""Drawer front panel thickness, m."""
SIDE = 0.012
"""Cabinet side and back boards, m."""


class DrawerLayout(NamedTuple):
    """A closed drawer in its cabinet's frame (m): the box's centre and outside size (front
    panel excluded), and the handle bar's centre."""

    centre: tuple[float, float, float]
    size: tuple[float, float, float]
    handle: tuple[float, float, float]


def drawer_layout(cabinet: FurnitureEntry, drawer: DrawerSpec) -> DrawerLayout:
    hx, hy, top = cabinet.size[0] / 2, cabinet.size[1] / 2, cabinet.size[2]
    bottom = top - CABINET_TOP - DRAWER_CLEARANCE - drawer.height
    depth = 2 * hx - SIDE - 0.01
    width = 2 * (hy - SIDE) - 0.01
    centre = (hx - depth / 2, 0.0, bottom + drawer.height / 2)
    panel_top = top - CABINET_TOP - 0.002
    handle = (hx + PANEL + drawer.handle_standoff, 0.0, panel_top - 0.035)
    return DrawerLayout(centre, (depth, width, drawer.height), handle)
