"""The spatial reasoner: world poses, relative poses, distances, "inside" and "on".

Conventions (the same as MuJoCo's and the simulator's):

- An element's placement is its ``pose`` property (a :class:`~wm_store.protocol.Pose`), or
  failing that its ``position`` (a :class:`~wm_store.protocol.Position`, identity rotation).
  It is expressed in the frame named by ``pose.frame`` (or ``pose.position.frame``): another
  element's id, or ``""`` for the world. World poses chain these frames up to the world.
- A pose is the *centre* of the element's bounding volume; ``size`` (``SizeCuboid`` x/y/z,
  ``SizeCylinder`` radius/height along z, ``SizeSphere``) is measured in the element's own frame.
- Quaternions are ``(x, y, z, w)``, Hamilton convention, normalised on read.

All methods are pure reads of the bound view: quick (a frame chain is a few dict look-ups) and
never blocking. They raise :class:`~wm_store.ElementNotFoundError` for an unknown id or
frame, :class:`~wm_store.reasoners.MissingDataError` when an element lacks the pose or
size a question needs, and :class:`~wm_store.reasoners.FrameCycleError` when frames form
a loop.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, NamedTuple

from wm_store._errors import ElementNotFoundError, ValidationError
from wm_store.protocol import (
    Element,
    Orientation,
    Pose,
    Position,
    SizeCuboid,
    SizeCylinder,
    SizeSphere,
    Value,
)
from wm_store.reasoners._base import FrameCycleError, MissingDataError
from wm_store.scene import SceneState

if TYPE_CHECKING:
    from wm_store.ontology import Ontology

__all__ = [
    "SpatialReasoner",
    "Transform",
    "quat_from_axes",
    "quat_from_yaw",
    "quat_multiply",
    "quat_rotate",
]

Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]

_IDENTITY: Quat = (0.0, 0.0, 0.0, 1.0)
_EPS = 1e-9
"""Boundaries count as inside: 1 nm of slack absorbs floating-point noise in frame chains."""


def quat_multiply(a: Quat, b: Quat) -> Quat:
    """Hamilton product ``a ⊗ b`` (apply ``b`` first, then ``a``)."""
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    )


def quat_rotate(q: Quat, v: Vec3) -> Vec3:
    """Rotate ``v`` by the unit quaternion ``q``."""
    qx, qy, qz, qw = q
    # t = 2 (q_xyz × v);  v' = v + w t + q_xyz × t
    tx = 2.0 * (qy * v[2] - qz * v[1])
    ty = 2.0 * (qz * v[0] - qx * v[2])
    tz = 2.0 * (qx * v[1] - qy * v[0])
    return (
        v[0] + qw * tx + (qy * tz - qz * ty),
        v[1] + qw * ty + (qz * tx - qx * tz),
        v[2] + qw * tz + (qx * ty - qy * tx),
    )


def quat_from_axes(x: Vec3, y: Vec3, z: Vec3) -> Quat:
    """The rotation whose columns are the orthonormal axes ``x``, ``y``, ``z`` (Shepperd's
    method, numerically safe for every rotation)."""
    m00, m10, m20 = x
    m01, m11, m21 = y
    m02, m12, m22 = z
    trace = m00 + m11 + m22
    if trace > 0:
        s = 2.0 * math.sqrt(trace + 1.0)
        q = ((m21 - m12) / s, (m02 - m20) / s, (m10 - m01) / s, 0.25 * s)
    elif m00 > m11 and m00 > m22:
        s = 2.0 * math.sqrt(1.0 + m00 - m11 - m22)
        q = (0.25 * s, (m01 + m10) / s, (m02 + m20) / s, (m21 - m12) / s)
    elif m11 > m22:
        s = 2.0 * math.sqrt(1.0 + m11 - m00 - m22)
        q = ((m01 + m10) / s, 0.25 * s, (m12 + m21) / s, (m02 - m20) / s)
    else:
        s = 2.0 * math.sqrt(1.0 + m22 - m00 - m11)
        q = ((m02 + m20) / s, (m12 + m21) / s, 0.25 * s, (m10 - m01) / s)
    n = math.sqrt(sum(c * c for c in q))
    qx, qy, qz, qw = (c / n for c in q)
    return (qx, qy, qz, qw) if qw >= 0 else (-qx, -qy, -qz, -qw)


def quat_from_yaw(yaw: float) -> Quat:
    """Rotation by ``yaw`` radians about the world z axis."""
    return (0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2))


class Transform(NamedTuple):
    """A rigid transform: rotate by ``rotation``, then translate by ``translation``."""

    translation: Vec3 = (0.0, 0.0, 0.0)
    rotation: Quat = _IDENTITY

    def compose(self, other: Transform) -> Transform:
        """``self ∘ other``: ``other`` is expressed in the frame ``self`` maps from."""
        r = quat_rotate(self.rotation, other.translation)
        t = self.translation
        return Transform(
            (t[0] + r[0], t[1] + r[1], t[2] + r[2]), quat_multiply(self.rotation, other.rotation)
        )

    def inverse(self) -> Transform:
        x, y, z, w = self.rotation
        conj = (-x, -y, -z, w)
        t = quat_rotate(conj, self.translation)
        return Transform((-t[0], -t[1], -t[2]), conj)

    def apply(self, point: Vec3) -> Vec3:
        r = quat_rotate(self.rotation, point)
        t = self.translation
        return (t[0] + r[0], t[1] + r[1], t[2] + r[2])

    def to_pose(self, frame: str = "") -> Pose:
        x, y, z = self.translation
        qx, qy, qz, qw = self.rotation
        return Pose(Position(x, y, z, frame), Orientation(qx, qy, qz, qw, frame), frame)


def _normalised(o: Orientation, owner: str) -> Quat:
    n = math.sqrt(o.x * o.x + o.y * o.y + o.z * o.z + o.w * o.w)
    if not n or not math.isfinite(n):
        raise MissingDataError(f"{owner} has an orientation that is not a rotation: {o}")
    return (o.x / n, o.y / n, o.z / n, o.w / n)


class SpatialReasoner:
    """Geometry over one scene view (the store's state or a client replica).

    ``pose_property`` / ``position_property`` / ``size_property`` name the data properties it
    reads. Holds no state of its own besides the view, so create one per view and keep it.
    """

    name = "spatial"
    data_codes = frozenset({"world_pose", "world_position"})
    relations_computed = frozenset({"contain", "on"})

    def __init__(
        self,
        view: SceneState,
        ontology: Ontology | None = None,
        *,
        pose_property: str = "pose",
        position_property: str = "position",
        size_property: str = "size",
    ) -> None:
        self.view = view
        self.ontology = ontology
        self.pose_property = pose_property
        self.position_property = position_property
        self.size_property = size_property
        self.properties_handled = frozenset({pose_property, position_property, size_property})

    # ------------------------------------------------------------------ frames

    def _element(self, ref: str | Element) -> Element:
        if isinstance(ref, Element):
            return ref
        element = self.view.get(ref)
        if element is None:
            raise ElementNotFoundError(f"no element {ref!r}")
        return element

    def local_transform(self, element: str | Element) -> tuple[Transform, str]:
        """The element's placement in its parent frame, and that frame (``""``: world)."""
        e = self._element(element)
        pose = e.properties.get(self.pose_property)
        if isinstance(pose, Pose):
            p = pose.position
            return (
                Transform((p.x, p.y, p.z), _normalised(pose.orientation, e.id)),
                pose.frame or p.frame,
            )
        position = e.properties.get(self.position_property)
        if isinstance(position, Position):
            return Transform((position.x, position.y, position.z)), position.frame
        raise MissingDataError(
            f"{e.id or 'the element'} ({e.type}) has no {self.pose_property!r} "
            f"or {self.position_property!r} property; observe or set its pose first"
        )

    def world_transform(self, element: str | Element) -> Transform:
        """The element's placement in the world, chaining frames. Raises
        :class:`FrameCycleError` if a frame is (indirectly) its own parent."""
        e = self._element(element)
        transform, frame = self.local_transform(e)
        seen = [e.id]
        while frame:
            if frame in seen:
                chain = " -> ".join([*seen, frame])
                raise FrameCycleError(f"pose frames form a cycle: {chain}")
            parent = self.view.get(frame)
            if parent is None:
                raise ElementNotFoundError(
                    f"{seen[-1]}'s pose is expressed in frame {frame!r}, which is no element"
                )
            seen.append(frame)
            parent_transform, frame = self.local_transform(parent)
            transform = parent_transform.compose(transform)
        return transform

    def world_pose(self, element: str | Element) -> Pose:
        return self.world_transform(element).to_pose()

    def world_position(self, element: str | Element) -> Position:
        x, y, z = self.world_transform(element).translation
        return Position(x, y, z)

    def relative_pose(self, element: str | Element, reference: str | Element) -> Pose:
        """Where ``element`` is relative to ``reference``: its pose in ``reference``'s frame."""
        ref = self._element(reference)
        t = self.world_transform(ref).inverse().compose(self.world_transform(element))
        return t.to_pose(ref.id)

    def distance(self, a: str | Element, b: str | Element) -> float:
        """Euclidean distance between the two elements' origins, in metres."""
        pa = self.world_transform(a).translation
        pb = self.world_transform(b).translation
        return math.dist(pa, pb)

    # ------------------------------------------------------------------ volumes

    def _points_in(self, element: str | Element, reference: Element, whole: bool) -> list[Vec3]:
        """``element``'s centre (or, with ``whole``, its bounding-box corners) in the frame of
        ``reference``."""
        to_ref = self.world_transform(reference).inverse().compose(self.world_transform(element))
        if not whole:
            return [to_ref.translation]
        hx, hy, hz = (d / 2 for d in self.extent(element))
        corners = [
            (sx * hx, sy * hy, sz * hz) for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)
        ]
        return [to_ref.apply(c) for c in corners]

    def extent(self, element: str | Element) -> Vec3:
        """The element's bounding-box dimensions (x, y, z) in its own frame."""
        e = self._element(element)
        size: Value = e.properties.get(self.size_property)
        match size:
            case SizeCuboid(x=x, y=y, z=z):
                return (x, y, z)
            case SizeCylinder(radius=r, height=h):
                return (2 * r, 2 * r, h)
            case SizeSphere(radius=r):
                return (2 * r, 2 * r, 2 * r)
        raise MissingDataError(
            f"{e.id or 'the element'} ({e.type}) has no {self.size_property!r} "
            "(SizeCuboid, SizeCylinder or SizeSphere); set its size first"
        )

    def is_inside(
        self,
        element: str | Element,
        container: str | Element,
        *,
        tolerance: float = 0.0,
        whole: bool = False,
    ) -> bool:
        """Whether ``element``'s centre (``whole``: its whole bounding box) lies within the
        container's volume (cuboid, cylinder or sphere around the container's pose), grown by
        ``tolerance`` metres. The boundary counts as inside."""
        box = self._element(container)
        size = box.properties.get(self.size_property)
        tolerance += _EPS
        for x, y, z in self._points_in(element, box, whole):
            match size:
                case SizeCylinder(radius=r, height=h):
                    ok = math.hypot(x, y) <= r + tolerance and abs(z) <= h / 2 + tolerance
                case SizeSphere(radius=r):
                    ok = math.sqrt(x * x + y * y + z * z) <= r + tolerance
                case _:
                    ex, ey, ez = self.extent(box)
                    ok = (
                        abs(x) <= ex / 2 + tolerance
                        and abs(y) <= ey / 2 + tolerance
                        and abs(z) <= ez / 2 + tolerance
                    )
            if not ok:
                return False
        return True

    def is_on(
        self, element: str | Element, surface: str | Element, *, tolerance: float = 0.01
    ) -> bool:
        """Whether ``element`` rests on top of ``surface``: its centre is over the surface's
        footprint (x/y within its size) and its lowest point (its centre if it has no size) is
        within ``tolerance`` metres of the surface's top face (the +z face in its frame)."""
        top = self._element(surface)
        sx, sy, sz = self.extent(top)
        cx, cy, _ = self._points_in(element, top, whole=False)[0]
        if abs(cx) > sx / 2 + _EPS or abs(cy) > sy / 2 + _EPS:
            return False
        e = self._element(element)
        has_size = e.properties.get(self.size_property) is not None
        bottom = min(p[2] for p in self._points_in(e, top, whole=has_size))
        return abs(bottom - sz / 2) <= tolerance + _EPS

    # ------------------------------------------------------------------ Reasoner protocol

    def get_data(self, element_id: str, code: str) -> Value:
        """``world_pose`` -> :class:`Pose` in the world; ``world_position`` -> :class:`Position`."""
        if code == "world_pose":
            return self.world_pose(element_id)
        if code == "world_position":
            return self.world_position(element_id)
        raise ValidationError(
            f"the spatial reasoner has no data {code!r}; it knows {sorted(self.data_codes)}"
        )

    def compute_relations(self, subject: str, obj: str) -> frozenset[str]:
        """The ontology relations the geometry supports from ``subject`` to ``obj``:
        ``contain`` if ``obj``'s centre is inside ``subject``'s volume, ``on`` if ``subject``
        rests on ``obj``. A question that lacks a pose or size simply gives no relation."""
        found: set[str] = set()
        try:
            if self.is_inside(obj, subject):
                found.add("contain")
        except MissingDataError:
            pass
        try:
            if self.is_on(subject, obj):
                found.add("on")
        except MissingDataError:
            pass
        return frozenset(found)
