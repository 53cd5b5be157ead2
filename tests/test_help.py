"""`--help` describes every option of every command: a walk over the click command tree."""

from __future__ import annotations

import click
from click.testing import CliRunner

from ked_cli.main import cli


def _commands(group: click.Group, ctx: click.Context, path: tuple[str, ...] = ()) -> list:
    out = []
    for name in group.list_commands(ctx):
        cmd = group.get_command(ctx, name)
        out.append((path + (name,), cmd))
        if isinstance(cmd, click.Group):
            out += _commands(cmd, click.Context(cmd, parent=ctx, info_name=name), path + (name,))
    return out


def _all() -> list:
    return _commands(cli, click.Context(cli, info_name="ked"))


def test_every_option_of_every_command_has_help_text():
    missing = [f"ked {' '.join(path)} {'/'.join(p.opts)}" for path, cmd in _all() for p in cmd.params
               if isinstance(p, click.Option) and not (p.help or "").strip()]
    assert missing == []


def test_every_command_help_runs_and_names_its_options():
    commands = _all()
    assert len(commands) >= 11  # the group's commands, the study and benchmark sub-commands
    for path, cmd in commands:
        res = CliRunner().invoke(cli, [*path, "--help"])
        assert res.exit_code == 0, (path, res.output)
        for p in cmd.params:
            if isinstance(p, click.Option) and not p.hidden:
                assert p.opts[0] in res.output, (path, p.opts)
