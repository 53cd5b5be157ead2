"""Studies that answer the harness's questions (issue 6): each one a checked-in campaign config under
``results/studies/`` plus one ``ked study <name>`` command that regenerates its HDF5 file(s), figures
and its own section of ``results/README.md``."""

from __future__ import annotations

import click


@click.group("study")
def study() -> None:
    """Regenerate a study: campaigns, HDF5 files, figures and its section of results/README.md."""


def _register() -> None:
    from compare.studies.validity import validity

    study.add_command(validity)


_register()
