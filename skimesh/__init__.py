"""skimesh application layer: the ``skimesh`` command line and the one-process demo.

- :mod:`skimesh.cli`: the console entry point (``main``) and how errors become exit codes;
- :mod:`skimesh.commands`: one module per sub-command;
- :mod:`skimesh.demo`: ``skimesh demo``'s services in one process, its mission and verification;
- :mod:`skimesh.recording`: the mission in rerun and the viewer's layout;
- :mod:`skimesh.runtime`: logging, a clean stop on signals, a settled heap (for every service);
- :mod:`skimesh.paths`: where the packaged configurations are; :mod:`skimesh.errors`: the errors.

Importing the package imports nothing else (the command's start-up time).
"""

__all__: list[str] = []
