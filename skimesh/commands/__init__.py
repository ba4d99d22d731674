"""The ``skimesh`` sub-commands: one public module per command, each with
``add_parser(subparsers)`` (:mod:`.router`, :mod:`.wm`, :mod:`.agent`, :mod:`.demo`, :mod:`.sim`,
:mod:`.task`, which also adds :mod:`.operator`).

The private modules are what the commands share or split off: ``_connect`` (a Zenoh session and
a world-model client for one command), ``_render`` (world-model content as terminal text),
``_wm_client`` (``skimesh wm ls/get/tree/...``), ``_plan`` (``skimesh task plan``) and
``_task_output`` (what ``skimesh task`` prints).
"""

__all__: list[str] = []
