"""The ``pipette`` command line: one typer group per module, joined in :mod:`.main`."""
