"""One module per ``groundsym`` subcommand (see :mod:`groundsym.cli`)."""
