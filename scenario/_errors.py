"""The root error of the scenario package.

Hierarchy::

    device_drivers.DeviceError
    └── device_drivers.ModelError
        └── ScenarioError       a scenario file cannot be found, read or is invalid

:class:`ScenarioError` derives from :class:`~device_drivers.ModelError` (so from
:class:`~device_drivers.DeviceError`) because a scenario builds the simulated world's model
and the command line reports every ``DeviceError`` the same way.
"""

from __future__ import annotations

from device_drivers import ModelError

__all__ = ["ScenarioError"]


class ScenarioError(ModelError):
    """A scenario file cannot be read or is invalid. The message starts with the file and
    names the field by its path (``$.parts[3].parent``) and, for a bad reference, the labels
    that do exist."""
