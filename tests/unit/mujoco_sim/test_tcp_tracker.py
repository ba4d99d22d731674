"""TcpTracker: one damped-least-squares step per call, solved with MuJoCo's Cholesky routines
for speed; checked against the textbook formulation in plain numpy."""

from __future__ import annotations

import math
from typing import Any

import mujoco
import numpy as np
import numpy.typing as npt
import pytest

from mujoco_sim.motion import TcpTracker
from scenario import RobotSpec

pytestmark = pytest.mark.sim

Array = npt.NDArray[np.float64]


def reference_step(
    tracker: TcpTracker, q: Array, position: Array, rotation: Array, *, whole_body: bool
) -> tuple[Array, float, float]:
    """One DLS step: dq = W J^T (J W W J^T + d^2 I)^-1 e, clipped to the joint limits; the
    residual is e minus the first-order change the step makes."""
    first = 0 if whole_body else tracker.n_base
    weights = np.ones(len(q))
    if whole_body:
        weights[: tracker.n_base] = 0.35
    weights = weights[first:]
    pos, rot = tracker.fk(q)
    m = rot @ rotation.T
    err = np.concatenate(
        [position - pos, 0.5 * np.array([m[1, 2] - m[2, 1], m[2, 0] - m[0, 2], m[0, 1] - m[1, 0]])]
    )
    model: Any = tracker._model
    data: Any = tracker._data
    jacp, jacr = np.zeros((3, model.nv)), np.zeros((3, model.nv))
    mujoco.mj_comPos(model, data)
    mujoco.mj_jacSite(model, data, jacp, jacr, tracker._site)
    jac = np.vstack([jacp, jacr])[:, tracker._dadr[first:]] * weights
    dq = jac.T @ np.linalg.solve(jac @ jac.T + 0.01**2 * np.eye(6), err)
    moved = np.clip(q[first:] + weights * dq, tracker.lower[first:], tracker.upper[first:])
    residual = err - jac @ ((moved - q[first:]) / weights)
    out = q.copy()
    out[first:] = moved
    return out, float(np.linalg.norm(residual[:3])), float(np.linalg.norm(residual[3:]))


@pytest.mark.parametrize("whole_body", [False, True])
def test_step_is_the_textbook_dls_step(spec: RobotSpec, whole_body: bool) -> None:
    tracker = TcpTracker(spec)
    rng = np.random.default_rng(7)
    n = len(tracker.chain)
    for _ in range(50):
        q = np.clip(rng.normal(0.0, 0.6, n), tracker.lower, tracker.upper)
        target = np.clip(q + rng.normal(0.0, 0.03, n), tracker.lower, tracker.upper)
        position, rotation = tracker.fk(target)
        got = tracker.step(q, position, rotation, whole_body=whole_body)
        want = reference_step(tracker, q, position, rotation, whole_body=whole_body)
        np.testing.assert_allclose(got[0], want[0], rtol=0, atol=1e-10)
        assert got[1] == pytest.approx(want[1], abs=1e-10)
        assert got[2] == pytest.approx(want[2], abs=1e-10)


def test_iterations_converge_and_stop_early(spec: RobotSpec) -> None:
    tracker = TcpTracker(spec)
    q = np.zeros(len(tracker.chain))
    q[tracker.n_base + 1 : tracker.n_base + 4] = (-0.4, 1.2, 0.8)
    goal = q.copy()
    goal[tracker.n_base :] += 0.02
    position, rotation = tracker.fk(goal)
    moved, pos_err, rot_err = tracker.step(q, position, rotation, whole_body=False, iterations=8)
    assert pos_err < 1e-4 and rot_err < 1e-3
    reached, _ = tracker.fk(moved)
    assert math.dist(reached, position) == pytest.approx(pos_err, abs=1e-12)  # measured
    still, *_ = tracker.step(moved, position, rotation, whole_body=False)
    np.testing.assert_array_equal(still, moved)  # converged: no step taken
