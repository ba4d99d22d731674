"""The skill agent's runtime, with no network of its own: hosts the runs of one agent.

:class:`AgentCore` starts, queues, pauses and stops runs (:class:`RunContext` is what a running
skill receives, :class:`RunWm` its world-model client), locks devices per run
(:class:`ResourceLocks`), records everything in an :class:`EventLog` and can draw outcomes
instead of moving hardware (:class:`SimulatedOutcomes`). An agent is configured from TOML
(:class:`AgentConfig`, :func:`load_config`), loads its skills as plug-ins
(:class:`SkillRegistry`) and binds its device drivers to world-model elements
(:func:`bind_devices`, :func:`bind_hardware`). Serving it over Zenoh is :mod:`skill_agent.server`.

Modules: ``_agent`` (AgentCore), ``_run`` (one run's lifecycle), ``_control`` (a run's state,
commands and events; RunEnv), ``_context`` (RunContext), ``_run_wm`` (its recorded world-model
view), ``_locks``, ``_event_log``, ``_simulated``, ``_config``, ``_plugins``, ``_wiring``.
"""

from ._agent import AgentCore as AgentCore
from ._agent import SkillEntry as SkillEntry
from ._config import AgentConfig as AgentConfig
from ._config import DeviceConfig as DeviceConfig
from ._config import RobotConfig as RobotConfig
from ._config import SensingConfig as SensingConfig
from ._config import ServiceSkillConfig as ServiceSkillConfig
from ._config import SimulationConfig as SimulationConfig
from ._config import SkillsConfig as SkillsConfig
from ._config import load_config as load_config
from ._config import parse_config as parse_config
from ._context import RunContext as RunContext
from ._event_log import EventLog as EventLog
from ._event_log import entry_agent as entry_agent
from ._event_log import entry_run as entry_run
from ._locks import LockStats as LockStats
from ._locks import ResourceLocks as ResourceLocks
from ._plugins import ENTRY_POINT_GROUP as ENTRY_POINT_GROUP
from ._plugins import SkillRegistry as SkillRegistry
from ._plugins import entry_point_skills as entry_point_skills
from ._run_wm import RunWm as RunWm
from ._simulated import SimulatedOutcomes as SimulatedOutcomes
from ._simulated import skill_probability as skill_probability
from ._wiring import WiringError as WiringError
from ._wiring import bind_devices as bind_devices
from ._wiring import bind_hardware as bind_hardware
from ._wiring import element_for_label as element_for_label

__all__ = [
    "ENTRY_POINT_GROUP",
    "AgentConfig",
    "AgentCore",
    "DeviceConfig",
    "EventLog",
    "LockStats",
    "ResourceLocks",
    "RobotConfig",
    "RunContext",
    "RunWm",
    "SensingConfig",
    "ServiceSkillConfig",
    "SimulatedOutcomes",
    "SimulationConfig",
    "SkillEntry",
    "SkillRegistry",
    "SkillsConfig",
    "WiringError",
    "bind_devices",
    "bind_hardware",
    "element_for_label",
    "entry_agent",
    "entry_point_skills",
    "entry_run",
    "load_config",
    "parse_config",
    "skill_probability",
]
