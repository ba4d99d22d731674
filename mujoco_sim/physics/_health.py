"""Detect a diverged simulation and turn it into a typed error.

The idea of dm_control's ``Physics.check_invalid_state``: MuJoCo itself notices NaN, Inf or
values above ``mjMAXVAL`` (1e10) in ``qpos``, ``qvel``, ``qacc`` and ``ctrl`` while stepping;
it then prints a warning, counts it in ``data.warning`` and *resets the state*, so the bad
numbers are gone by the time ``mj_step`` returns. :func:`check_state` therefore reads those
counters first, then scans the state itself (for states written by hand or by a driver) and
flags accelerations above a bound long before MuJoCo's own limit.
"""

from __future__ import annotations

import math
from typing import Any

import mujoco
import numpy as np

from device_drivers import SimulationDivergedError

__all__ = ["DEFAULT_MAX_ACCELERATION", "check_state"]

DEFAULT_MAX_ACCELERATION = 1e6
"""Largest plausible |qacc| (rad/s² or m/s²) for the robots here: a stiff finger servo at full
force gives ~1e3, impacts ~1e4."""

# MuJoCo warning → (MjData field, what its ``lastinfo`` index points into)
_WARNINGS = {
    mujoco.mjtWarning.mjWARN_BADQPOS: ("qpos", "qpos"),
    mujoco.mjtWarning.mjWARN_BADQVEL: ("qvel", "dof"),
    mujoco.mjtWarning.mjWARN_BADQACC: ("qacc", "dof"),
    mujoco.mjtWarning.mjWARN_BADCTRL: ("ctrl", "actuator"),
}


def check_state(
    model: Any, data: Any, *, max_acceleration: float = DEFAULT_MAX_ACCELERATION
) -> None:
    """Raise :class:`SimulationDivergedError` if ``data`` is or was diverged.

    Checks, in order: MuJoCo's bad-state warning counters (set by a step that found and reset a
    bad state), non-finite ``qpos``/``qvel``/``qacc``/``ctrl``/``act``, and
    ``|qacc| > max_acceleration``. The error names the simulation time, the field and the joint
    (or actuator) of the first bad entry. ``model``/``data`` are ``MjModel``/``MjData``
    (``Any``: the bindings ship no types). Cheap: one pass of sums and a maximum
    over the state; only a state that fails it is searched for the culprit.
    """
    if _looks_sound(data, max_acceleration):
        return
    for warning, (field, kind) in _WARNINGS.items():
        record = data.warning[warning]
        if record.number > 0:
            raise SimulationDivergedError(
                f"MuJoCo found NaN/Inf/huge values {record.number} time(s) and reset the state",
                time=float(data.time),
                culprit=_name(model, kind, int(record.lastinfo)),
                field=field,
            )
    for field, kind in (("qpos", "qpos"), ("qvel", "dof"), ("qacc", "dof"), ("ctrl", "actuator")):
        values = getattr(data, field)
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size:
            raise SimulationDivergedError(
                f"{bad.size} non-finite value(s), first {values[bad[0]]} at index {bad[0]}",
                time=float(data.time),
                culprit=_name(model, kind, int(bad[0])),
                field=field,
            )
    if data.act.size and not np.all(np.isfinite(data.act)):
        raise SimulationDivergedError(
            "non-finite actuator activation", time=float(data.time), culprit=None, field="act"
        )
    worst = int(np.argmax(np.abs(data.qacc))) if data.qacc.size else 0
    if data.qacc.size and abs(data.qacc[worst]) > max_acceleration:
        raise SimulationDivergedError(
            f"acceleration {data.qacc[worst]:.3g} above the bound {max_acceleration:.3g}",
            time=float(data.time),
            culprit=_name(model, "dof", worst),
            field="qacc",
        )


_WARNING_IDS = np.array([int(w) for w in _WARNINGS])


def _looks_sound(data: Any, max_acceleration: float) -> bool:
    """The quick test run after every batch: no bad-state warning, finite sums (a NaN or an
    infinity anywhere makes its field's sum non-finite) and every ``|qacc|`` within the bound
    (a NaN fails the comparison). False does not mean diverged: an overflowing sum of finite
    values, for one, sends the state to the exact scans of :func:`check_state`."""
    if data.warning.number[_WARNING_IDS].any():
        return False
    qacc = data.qacc
    with np.errstate(all="ignore"):  # overflow, inf - inf: the exact scans will tell
        total = float(data.qpos.sum()) + float(data.qvel.sum()) + float(data.ctrl.sum())
        if data.act.size:
            total += float(data.act.sum())
        if not math.isfinite(total):
            return False
        return not qacc.size or bool(np.abs(qacc).max() <= max_acceleration)


def _name(model: Any, kind: str, index: int) -> str | None:
    """Joint (or actuator) name for an index into qpos, a dof or an actuator; falls back to the
    joint's body, then to ``None``."""
    if kind == "actuator":
        return str(model.actuator(index).name) if 0 <= index < model.nu else None
    if kind == "dof":
        if not 0 <= index < model.nv:
            return None
        joint = int(model.dof_jntid[index])
    else:
        if not 0 <= index < model.nq:
            return None
        joint = int(np.searchsorted(model.jnt_qposadr, index, side="right")) - 1
    name = str(model.joint(joint).name)
    return name or f"body {model.body(int(model.jnt_bodyid[joint])).name}"
