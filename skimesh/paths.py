"""Where the packaged data lives: ``configs/`` at the repository root (editable install) or
inside the package (wheel)."""

from __future__ import annotations

from pathlib import Path

__all__ = ["config_path", "configs_dir"]

_HERE = Path(__file__).resolve().parent


def configs_dir() -> Path:
    for candidate in (_HERE / "configs", _HERE.parent / "configs"):
        if candidate.is_dir():
            return candidate
    raise FileNotFoundError(f"skimesh configs not found next to {_HERE}")


def config_path(*parts: str) -> Path:
    path = configs_dir().joinpath(*parts)
    if not path.exists():
        raise FileNotFoundError(f"no {'/'.join(parts)} in {configs_dir()}")
    return path
