"""Studies that answer the harness's questions (issue 6): each one a checked-in campaign config under
``results/studies/`` plus one ``ked study <name>`` command that regenerates its HDF5 file(s), figures
and its own section of ``results/README.md``."""

from __future__ import annotations

import click


@click.group("study")
def study() -> None:
    """Regenerate a study: campaigns, HDF5 files, figures and its section of results/README.md."""


def _register() -> None:
    from compare.studies.stability import stability
    from compare.studies.validity import validity
    from compare.studies.work_precision import work_precision

    study.add_command(validity)
    study.add_command(work_precision)
    study.add_command(stability)


_register()
