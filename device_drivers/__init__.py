"""skimesh device layer: typed device interfaces, the MuJoCo world, robot models and IK."""

__all__: list[str] = []
