"""The ``ked`` group: commands are imported only when they run (fast start-up), and no error reaches
the user as a traceback (:mod:`ked_cli.errors`)."""

from __future__ import annotations

import importlib

import click

from ked_cli.errors import check_memory_limit, run_guarded

# command -> (module, attribute, one-line help shown by `ked --help` without importing the module)
COMMANDS = {
    "run": ("ked_cli.campaign", "run_cmd", "Run a comparison campaign (the default one without CONFIG)."),
    "inspect": ("ked_cli.campaign", "inspect_cmd", "Show a results file: summary, one scene, or --verify."),
    "plot": ("ked_cli.campaign", "plot_cmd", "Draw the figures (PNG, SVG or PDF) of a results file."),
    "diff": ("ked_cli.diff", "diff_cmd", "Compare a results file with a baseline on agreement tolerances (CI)."),
    "merge": ("ked_cli.campaign", "merge_cmd", "Add the scenes of one results file (e.g. a rescue file) to another."),
    "quasi": ("ked_cli.quasi", "quasi", "Quasi-static KED solve of one scene."),
    "linear": ("ked_cli.linear", "linear", "Linear time-periodic KED steady state and Floquet stability of one scene."),
    "simulate": ("ked_cli.simulate", "simulate", "Exudyn flexible-multibody steady state of one scene."),
    "check": ("ked_cli.check", "check", "Design check: how wrong is quasi-static here, and which model is needed."),
    "thesis": ("ked_cli.thesis", "thesis", "Tables I-III of the thesis: published / as printed / corrected."),
    "benchmark": ("ked_cli.benchmark", "benchmark", "Published benchmarks reproduced (Simeon's slider-crank)."),
    "study": ("ked_cli.study", "study", "Regenerate a study: campaigns, HDF5 files, figures, README section."),
}


class LazyGroup(click.Group):
    """A click group whose commands are imported on first use."""

    def list_commands(self, ctx: click.Context) -> list[str]:
        return list(COMMANDS)

    def get_command(self, ctx: click.Context, name: str) -> click.Command | None:
        if name not in COMMANDS:
            return None
        module, attr, _ = COMMANDS[name]
        return getattr(importlib.import_module(module), attr)

    def format_commands(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        with formatter.section("Commands"):
            formatter.write_dl([(name, text) for name, (_, _, text) in COMMANDS.items()])


@click.group(cls=LazyGroup, context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 100})
@click.version_option(package_name="ked-harness")
def cli() -> None:
    """ked-harness: when can a quasi-static elastic analysis of a fast four-bar be trusted?"""


def main() -> None:
    """Entry point of the ``ked`` script."""
    check_memory_limit()
    run_guarded(cli)
