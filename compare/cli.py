"""The `ked` command line: one click group; each command lives in its own module."""

from __future__ import annotations

import click

from compare.campaign_cli import inspect_cmd, plot_cmd, run_cmd
from compare.studies import study
from exudyn_models.cli import simulate
from ked_quasi.cli import quasi
from ked_quasi.thesis_cli import thesis


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="ked-harness")
def main() -> None:
    """ked-harness: when can a quasi-static elastic analysis of a fast four-bar be trusted?"""


main.add_command(quasi)
main.add_command(simulate)
main.add_command(run_cmd)
main.add_command(inspect_cmd)
main.add_command(plot_cmd)
main.add_command(thesis)
main.add_command(study)
