"""Devices over the mesh: :func:`serve_devices` answers device commands for a set of drivers;
:func:`connect_devices` returns proxies that implement the device interfaces remotely.

Both speak the wire schema of :mod:`device_drivers.protocol` over a :class:`meshlink.Mesh`.
"""

from __future__ import annotations

from ._client import RemoteAppliance as RemoteAppliance
from ._client import RemoteArm as RemoteArm
from ._client import RemoteBase as RemoteBase
from ._client import RemoteDevice as RemoteDevice
from ._client import RemoteGripper as RemoteGripper
from ._client import RemoteSensor as RemoteSensor
from ._client import connect_devices as connect_devices
from ._server import device_kind as device_kind
from ._server import serve_devices as serve_devices

__all__ = [
    "RemoteAppliance",
    "RemoteArm",
    "RemoteBase",
    "RemoteDevice",
    "RemoteGripper",
    "RemoteSensor",
    "connect_devices",
    "device_kind",
    "serve_devices",
]
