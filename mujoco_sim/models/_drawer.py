"""A cabinet with a drawer (MjSpec): the ``cabinet`` furniture shape of a scenario.

In the cabinet's frame (origin on the floor at its centre, +x its front)::

    top board          CABINET_TOP thick, the cabinet's support surface
    slot               the drawer's height + DRAWER_CLEARANCE above and below, open at +x
    lower block        solid, from the floor to the slot

The drawer (body ``<drawer label>``) slides on the joint ``<drawer label>/slide`` along +x,
from 0 (closed: its front panel against the cabinet's front) to ``travel``. It is an open box
(floor, sides, back) behind a front panel that covers the slot, with a bar handle
(geom ``<drawer label>/handle``) held ``handle_standoff`` m out from the panel by two posts:
a finger fits between the bar and the panel, so a gripper pinching the bar along x pulls the
drawer with its rear finger and pushes it shut with its front one, whatever the friction. The
joint is damped and has some dry friction, so the drawer stays where it is left. Cabinet and
drawer do not collide with each other (the joint's range keeps the drawer in its slot).

The numbers the world model needs too come from :mod:`scenario`, so the
scene and the world model cannot disagree.
"""

from __future__ import annotations

import mujoco

from scenario import (
    CABINET_TOP,
    DRAWER_CLEARANCE,
    HANDLE_HALF,
    PANEL,
    SIDE,
    WALL,
    DrawerSpec,
    FurnitureEntry,
    drawer_layout,
)

__all__ = ["add_cabinet"]

_BOX = mujoco.mjtGeom.mjGEOM_BOX


def add_cabinet(world: mujoco.MjSpec, body: mujoco.MjsBody, f: FurnitureEntry) -> None:
    """The carcass of cabinet ``f`` in ``body`` (its frame) and, if it has one, its drawer."""
    hx, hy, top = f.size[0] / 2, f.size[1] / 2, f.size[2]
    rgba = list(f.rgba)
    slot_h = (f.drawer.height if f.drawer else 0.0) + 2 * DRAWER_CLEARANCE
    low = top - CABINET_TOP - slot_h  # top of the lower block
    _box(body, f"{f.label}/top", [hx, hy, CABINET_TOP / 2], [0, 0, top - CABINET_TOP / 2], rgba)
    _box(body, f"{f.label}/block", [hx, hy, low / 2], [0, 0, low / 2], rgba)
    if f.drawer is None:
        return
    z_slot = low + slot_h / 2
    for sy in (-1, 1):
        pos = [0, sy * (hy - SIDE / 2), z_slot]
        _box(body, f"{f.label}/side_{sy:+d}", [hx, SIDE / 2, slot_h / 2], pos, rgba)
    back = [SIDE / 2, hy - SIDE, slot_h / 2]
    _box(body, f"{f.label}/back", back, [-hx + SIDE / 2, 0, z_slot], rgba)
    _drawer(world, body, f, f.drawer, low)


def _drawer(
    world: mujoco.MjSpec, cabinet: mujoco.MjsBody, f: FurnitureEntry, d: DrawerSpec, low: float
) -> None:
    layout = drawer_layout(f, d)
    hx = f.size[0] / 2
    drawer = cabinet.add_body(name=d.label)
    drawer.add_joint(
        name=f"{d.label}/slide",
        type=mujoco.mjtJoint.mjJNT_SLIDE,
        axis=[1, 0, 0],
        range=[0, d.travel],
        damping=3.0,
        frictionloss=0.5,
        armature=0.05,
    )
    (cx, _, cz), (depth, width, height) = layout.centre, layout.size
    rgba = list(d.rgba)
    parts = (  # name, half sizes, centre, mass
        ("floor", [depth / 2, width / 2, WALL / 2], [cx, 0, cz - height / 2 + WALL / 2], 0.6),
        ("back", [WALL / 2, width / 2, height / 2], [cx - depth / 2 + WALL / 2, 0, cz], 0.2),
        ("side_+1", [depth / 2, WALL / 2, height / 2], [cx, width / 2 - WALL / 2, cz], 0.2),
        ("side_-1", [depth / 2, WALL / 2, height / 2], [cx, -width / 2 + WALL / 2, cz], 0.2),
    )
    for name, half, pos, mass in parts:
        _box(drawer, f"{d.label}/{name}", half, pos, rgba, mass=mass)
    panel_lo, panel_hi = low + 0.002, f.size[2] - CABINET_TOP - 0.002
    panel = [PANEL / 2, f.size[1] / 2 - 0.004, (panel_hi - panel_lo) / 2]
    panel_pos = [hx + PANEL / 2, 0, (panel_hi + panel_lo) / 2]
    _box(drawer, f"{d.label}/front", panel, panel_pos, rgba, mass=0.4)
    hx_, hy_, _ = HANDLE_HALF
    bar_x, _, bar_z = layout.handle
    dark = [0.25, 0.25, 0.28, 1.0]
    _box(drawer, f"{d.label}/handle", list(HANDLE_HALF), [bar_x, 0, bar_z], dark, mass=0.05)
    post_len = d.handle_standoff - hx_
    for sy in (-1, 1):
        pos = [hx + PANEL + post_len / 2, sy * (hy_ - 0.01), bar_z]
        _box(drawer, f"{d.label}/post_{sy:+d}", [post_len / 2, 0.006, 0.006], pos, dark, mass=0.01)
    world.add_exclude(bodyname1=f.label, bodyname2=d.label)


def _box(
    body: mujoco.MjsBody,
    name: str,
    half: list[float],
    pos: list[float],
    rgba: list[float],
    mass: float | None = None,
) -> None:
    extra = {} if mass is None else {"mass": mass}
    body.add_geom(name=name, type=_BOX, size=half, pos=pos, rgba=rgba, **extra)
