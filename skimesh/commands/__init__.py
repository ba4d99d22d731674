"""One module per ``skimesh`` sub-command group; each exposes ``add_parser(subparsers)``."""
