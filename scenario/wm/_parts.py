"""Parts in the world-model scene (see :func:`scenario.wm.scenario_ops`): their size by shape,
and the error of their prior pose when the scenario sets ``prior_noise`` (drawn from the label,
so the scene is the same every time; ``locate`` refines it).
"""

from __future__ import annotations

import random
import zlib

from scenario._schema import PartEntry
from wm_store.protocol import SizeCuboid, SizeCylinder, SizeSphere, Value

__all__ = ["part_size", "prior_error"]


def prior_error(label: str, noise: float) -> tuple[float, float]:
    """The x, y error of ``label``'s prior pose: Gaussian, ``noise`` m standard deviation,
    drawn from the label (the same scene every time), at most 3 standard deviations."""
    if noise <= 0:
        return 0.0, 0.0
    draw = random.Random(zlib.crc32(label.encode()))
    limit = 3 * noise
    dx, dy = (max(-limit, min(limit, draw.gauss(0.0, noise))) for _ in range(2))
    return dx, dy


def part_size(p: PartEntry) -> Value:
    if p.shape == "cylinder":
        return SizeCylinder(radius=p.size[0], height=p.size[1])
    if p.shape == "sphere":
        return SizeSphere(radius=p.size[0])
    return SizeCuboid(x=p.size[0], y=p.size[1], z=p.size[2])
