"""skimesh world model: an ontology-typed scene graph served as a revisioned, durable Zenoh
key-value store that publishes every change, and an async client that keeps a local replica."""

__all__: list[str] = []
