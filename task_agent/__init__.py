"""skimesh task layer: discovery, planning, multi-robot execution, verification."""

__all__: list[str] = []
