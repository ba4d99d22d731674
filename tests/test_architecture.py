"""The architecture, checked from the source.

- Layers import downwards only::

      skimesh (CLI, demo, recording)
      task_agent
      skill_agent                  mujoco_sim (the MuJoCo world)
      scenario (scenario files, start poses, the world-model scene)
      wm_store          device_drivers
      meshlink (Zenoh, the bridge, the RPC layer)

- Only ``meshlink`` imports ``zenoh``; only ``mujoco_sim`` imports ``mujoco`` or ``placo``; the
  world model's core does not touch the network (only its adapters import ``meshlink``; the
  core may use ``meshlink.rpc``, the RPC wire and request handling, which opens no session).
- A concept is a sub-package whose ``__init__`` is its face: private modules (``_name.py``)
  are imported only from inside their own package; no directory keeps a family of
  three or more modules sharing a filename prefix; each public name has one public import path.
- Every exception a package defines derives from that package's root.
"""

from __future__ import annotations

import ast
import importlib
import inspect
import pkgutil
from collections import defaultdict
from pathlib import Path
from types import ModuleType

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = [
    "meshlink",
    "wm_store",
    "device_drivers",
    "scenario",
    "mujoco_sim",
    "skill_agent",
    "task_agent",
    "skimesh",
]

ALLOWED: dict[str, set[str]] = {
    "meshlink": set(),
    "wm_store": {"meshlink"},
    "device_drivers": {"meshlink"},
    "scenario": {"meshlink", "wm_store", "device_drivers"},
    "mujoco_sim": {"meshlink", "device_drivers", "scenario"},
    "skill_agent": {"meshlink", "wm_store", "device_drivers", "scenario"},
    "task_agent": {"meshlink", "wm_store", "device_drivers", "scenario", "skill_agent"},
    "skimesh": set(PACKAGES),
}

# The exception root of each package: every exception class defined in it derives from this.
# mujoco_sim defines none of its own: it raises the device layer's errors, which clients rebuild
# by name across the wire.
ROOT_ERRORS = {
    "meshlink": "meshlink:MeshlinkError",
    "wm_store": "wm_store:WmError",
    "device_drivers": "device_drivers:DeviceError",
    "scenario": "scenario:ScenarioError",
    "mujoco_sim": "device_drivers:DeviceError",
    "skill_agent": "skill_agent:SkillError",
    "task_agent": "task_agent:TaskError",
    "skimesh": "skimesh.errors:SkimeshError",
}

# wm_store modules allowed to talk to the network (import zenoh or meshlink): the adapters.
WM_ADAPTERS = {"wm_store/_zenoh_transport", "wm_store/server/_zenoh", "wm_store/server/_presence"}
NETWORK = {"zenoh", "meshlink"}
# meshlink's RPC layer (error reply, codec, request handler, raising by code) opens no session:
# the world model's core answers and decodes its requests with it.
WIRE = "meshlink.rpc"
SIMULATOR = {"mujoco", "placo", "pinocchio"}


def modules(package: str) -> list[Path]:
    return sorted((ROOT / package).rglob("*.py"))


def dotted(path: Path) -> str:
    rel = path.relative_to(ROOT).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def absolute_imports(path: Path) -> list[str]:
    """Every module path ``path`` imports, relative imports resolved, ``from m import n`` as
    ``m.n`` (n may be a module or a name: both are checked the same way)."""
    tree = ast.parse(path.read_text(), filename=str(path))
    here = dotted(path)
    package = here if path.name == "__init__.py" else here.rpartition(".")[0]
    found: list[str] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found.extend(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - (node.level - 1)]
                module = ".".join([*base, node.module] if node.module else base)
            else:
                module = node.module or ""
            found.append(module)
            found.extend(f"{module}.{alias.name}" for alias in node.names)
    return found


def top_levels(path: Path) -> set[str]:
    return {name.split(".")[0] for name in absolute_imports(path)}


@pytest.mark.parametrize("package", PACKAGES)
def test_layers_import_downwards_only(package: str) -> None:
    forbidden = set(PACKAGES) - ALLOWED[package] - {package}
    for path in modules(package):
        bad = top_levels(path) & forbidden
        assert not bad, f"{path.relative_to(ROOT)} imports {sorted(bad)} (layering)"


def test_world_model_core_is_transport_free() -> None:
    for path in modules("wm_store"):
        rel = str(path.relative_to(ROOT).with_suffix(""))
        if any(rel == a or rel.startswith(a + "/") for a in WM_ADAPTERS):
            continue
        names = [n for n in absolute_imports(path) if n != WIRE and not n.startswith(WIRE + ".")]
        bad = {name.split(".")[0] for name in names} & NETWORK
        assert not bad, f"{rel} is core but imports {sorted(bad)}; only adapters may"


def test_only_meshlink_talks_to_zenoh() -> None:
    """Every thread/async crossing with Zenoh lives in meshlink; the rest use its API."""
    for package in PACKAGES:
        if package == "meshlink":
            continue
        for path in modules(package):
            assert "zenoh" not in top_levels(path), f"{path.relative_to(ROOT)} imports zenoh"


def test_only_mujoco_sim_touches_the_simulator() -> None:
    """A real-robot driver package can sit beside mujoco_sim using device_drivers alone."""
    for package in PACKAGES:
        if package == "mujoco_sim":
            continue
        for path in modules(package):
            bad = top_levels(path) & SIMULATOR
            assert not bad, f"{path.relative_to(ROOT)} imports {sorted(bad)}; only mujoco_sim may"


def is_private(dotted_path: str) -> bool:
    return any(
        part.startswith("_") and not part.startswith("__") for part in dotted_path.split(".")
    )


def test_private_modules_stay_inside_their_package() -> None:
    """``pkg.sub._m`` is imported only by modules of ``pkg``: other packages use the faces."""
    offenders = []
    for package in PACKAGES:
        for path in modules(package):
            for name in absolute_imports(path):
                if (
                    name.split(".")[0] in PACKAGES
                    and name.split(".")[0] != package
                    and is_private(name)
                ):
                    offenders.append(f"{dotted(path)} imports {name}")
    assert not offenders, "private modules imported from outside:\n" + "\n".join(offenders)


def directories() -> list[Path]:
    return sorted({path.parent for package in PACKAGES for path in modules(package)})


@pytest.mark.parametrize("directory", directories(), ids=lambda d: str(d.relative_to(ROOT)))
def test_no_family_of_prefixed_modules(directory: Path) -> None:
    """A family of modules grouped only by a filename prefix is a sub-package waiting to be."""
    names = [
        (p.stem if p.is_file() else p.name).lstrip("_")
        for p in directory.iterdir()
        if (p.suffix == ".py" and p.stem != "__init__") or (p / "__init__.py").exists()
    ]
    families: dict[str, list[str]] = defaultdict(list)
    for name in names:
        families[name.split("_")[0]].append(name)
    crowded = {k: v for k, v in families.items() if len(v) >= 3}
    assert not crowded, f"{directory.relative_to(ROOT)}: {crowded}"


def public_modules() -> list[ModuleType]:
    found: list[ModuleType] = []
    for package in PACKAGES:
        top = importlib.import_module(package)
        found.append(top)
        for info in pkgutil.walk_packages(top.__path__, prefix=f"{package}."):
            if is_private(info.name) or info.name.endswith("__main__"):
                continue
            found.append(importlib.import_module(info.name))
    return found


@pytest.mark.parametrize("package", PACKAGES)
def test_public_api_exists(package: str) -> None:
    for module in public_modules():
        if module.__name__.split(".")[0] != package:
            continue
        exported = getattr(module, "__all__", None)
        if exported is None:
            assert not hasattr(module, "__path__"), f"{module.__name__} (a face) has no __all__"
            continue
        missing = [name for name in exported if not hasattr(module, name)]
        assert not missing, f"{module.__name__}.__all__ names missing attributes: {missing}"
        assert len(set(exported)) == len(exported), f"{module.__name__}.__all__ repeats a name"


def test_each_public_name_has_one_import_path() -> None:
    """A class or function is exported (``__all__``) by one public module only."""
    seen: dict[int, list[str]] = defaultdict(list)
    for module in public_modules():
        for name in getattr(module, "__all__", []):
            obj = getattr(module, name)
            if inspect.isclass(obj) or inspect.isfunction(obj):
                seen[id(obj)].append(f"{module.__name__}.{name}")
    repeated = sorted(paths for paths in seen.values() if len(paths) > 1)
    assert not repeated, "exported from more than one place:\n" + "\n".join(map(str, repeated))


@pytest.mark.parametrize("package", PACKAGES)
def test_one_exception_root(package: str) -> None:
    top = importlib.import_module(package)
    where, _, name = ROOT_ERRORS[package].partition(":")
    root = getattr(importlib.import_module(where), name)
    strays = []
    for module in [top, *_all_submodules(top)]:
        for _, obj in inspect.getmembers(module, inspect.isclass):
            if (
                issubclass(obj, BaseException)
                and obj.__module__ == module.__name__
                and not issubclass(obj, root)
            ):
                strays.append(f"{module.__name__}.{obj.__name__}")
    assert not strays, f"exceptions outside {package}.{root.__name__}: {strays}"


def _all_submodules(top: ModuleType) -> list[ModuleType]:
    return [
        importlib.import_module(info.name)
        for info in pkgutil.walk_packages(top.__path__, prefix=f"{top.__name__}.")
        if not info.name.endswith("__main__")
    ]
