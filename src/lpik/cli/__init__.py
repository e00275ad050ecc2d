"""The ``lpik`` command line: one module per subcommand, registered in :mod:`lpik.cli.main`."""
