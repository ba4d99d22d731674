"""skimesh application layer: the ``skimesh`` command line and the one-process demo."""

__all__: list[str] = []
