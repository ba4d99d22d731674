"""skimesh transport layer: Zenoh sessions, the key space and the anyio <-> Zenoh bridge."""

__all__: list[str] = []
