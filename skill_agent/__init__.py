"""skimesh skill layer: the skill model, the async skill agent runtime and the standard skills."""

__all__: list[str] = []
