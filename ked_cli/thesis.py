"""``ked thesis``: the thesis's Tables I-III published, as printed (emulated listings) and corrected."""

from __future__ import annotations

import json

import click
import numpy as np

from ked_quasi.thesis import (
    QUIRKS_BY_TABLE,
    ThesisQuirks,
    ThesisTable,
    as_printed,
    corrected,
    corrected_mass_model,
    published_table,
    quirk_effects,
    quirk_walk,
)
from ked_quasi.thesis_tables import TABLE_KEYS, TABLE_TITLES, TABLES, is_typo

GROUPS = ("published", "as_printed", "corrected")
_HEAD = ("X", "Y", "src dX", "src dY", "cog dX", "cog dY")


def _parse_quirks(items: tuple[str, ...]) -> ThesisQuirks:
    q = ThesisQuirks()
    for item in items:
        name, sep, state = item.partition("=")
        state = state.strip().lower()
        if not sep or state not in ("on", "off"):
            raise click.BadParameter(f"expected NAME=on or NAME=off, got {item!r}", param_hint="--quirk")
        value = state == "on"
        names = ThesisQuirks.names() if name.strip() == "all" else (name.strip(),)
        try:
            q = q.with_(**{n: value for n in names})
        except ValueError as exc:
            raise click.BadParameter(str(exc), param_hint="--quirk") from None
    return q


def _groups(table: str, groups: tuple[str, ...], q: ThesisQuirks) -> dict[str, ThesisTable]:
    out: dict[str, ThesisTable] = {}
    for g in groups:
        if g == "published":
            out[g] = published_table(table)
        elif g == "as_printed":
            out[g] = as_printed(table, q)
        else:
            out[g] = corrected(table)
    return out


def _render(table: str, tabs: dict[str, ThesisTable], diff: bool) -> str:
    w = 9
    lines = [f"TABLE {table}  {TABLE_TITLES[table]}  (inches; * = printed entry listed as a typo)"]
    groups = list(tabs)
    lines.append(" " * 5 + "".join(f" | {g.replace('_', '-'):<{6 * w}}" for g in groups))
    lines.append(f"{'deg':>5}" + "".join(" |" + "".join(f"{h:>{w - 1}} " for h in _HEAD) for _ in groups))
    pairs: list[tuple[str, str]] = []
    if diff:
        pairs = [(a, b) for a, b in (("as_printed", "published"), ("corrected", "published"),
                                     ("corrected", "as_printed")) if a in tabs and b in tabs]
    ref = next(iter(tabs.values()))
    for i, deg in enumerate(ref.crank_angle_deg):
        row = f"{deg:5.0f}"
        for g in groups:
            row += " |"
            for k in TABLE_KEYS[1:]:
                mark = "*" if g == "published" and is_typo(table, float(deg), k) else " "
                row += f"{float(tabs[g].column(k)[i]):{w - 1}.3f}{mark}"
        lines.append(row)
    for a, b in pairs:
        lines.append(f"  {a.replace('_', '-')} - {b.replace('_', '-')}:")
        for i, deg in enumerate(ref.crank_angle_deg):
            d = [float(tabs[a].column(k)[i] - tabs[b].column(k)[i]) for k in TABLE_KEYS[1:]]
            lines.append(f"{deg:5.0f} |" + "".join(f"{v:{w}.4f}" for v in d))
        dev = [float(np.max(np.abs(tabs[a].column(k) - tabs[b].column(k)))) for k in TABLE_KEYS[1:]]
        lines.append("  max |" + "".join(f"{v:{w}.4f}" for v in dev))
    return "\n".join(lines)


def _render_narrow(table: str, tabs: dict[str, ThesisTable], diff: bool) -> str:
    """The same numbers for a 100-column terminal: one group after the other, differences as their
    largest magnitude per column (``--wide`` prints the rows side by side and every difference)."""
    w = 9
    head = f"{'deg':>5} |" + "".join(f"{h:>{w - 1}} " for h in _HEAD)
    lines = [f"TABLE {table}  {TABLE_TITLES[table]}  (inches; * = printed entry listed as a typo)"]
    ref = next(iter(tabs.values()))
    for g, tab in tabs.items():
        lines += [f"  {g.replace('_', '-')}", head]
        for i, deg in enumerate(ref.crank_angle_deg):
            cells = "".join(f"{float(tab.column(k)[i]):{w - 1}.3f}"
                            + ("*" if g == "published" and is_typo(table, float(deg), k) else " ")
                            for k in TABLE_KEYS[1:])
            lines.append(f"{deg:5.0f} |{cells}")
    pairs = [(a, b) for a, b in (("as_printed", "published"), ("corrected", "published"), ("corrected", "as_printed"))
             if diff and a in tabs and b in tabs]
    if pairs:
        lines += ["  largest |difference| per column (rows: --wide)",
                  f"{'':>24} |" + "".join(f"{h:>{w}}" for h in _HEAD)]
    for a, b in pairs:
        dev = [float(np.max(np.abs(tabs[a].column(k) - tabs[b].column(k)))) for k in TABLE_KEYS[1:]]
        lines.append(f"{a.replace('_', '-') + ' - ' + b.replace('_', '-'):>24} |" + "".join(f"{v:{w}.4f}" for v in dev))
    return "\n".join(lines)


def _effect_cell(v: object, kind: str) -> str:
    if v is None:
        return "-"
    e = v[kind]  # type: ignore[index]

    def fmt(x: float) -> str:
        return "0" if x == 0 else f"{x:.4f}" if x >= 1e-4 else f"{x:.1e}"

    return f"{fmt(e['source'])} / {fmt(e['cognate'])}"


@click.command("thesis")
@click.option("--table", "tables", multiple=True, type=click.Choice(TABLES), help="Table(s) to show (default all).")
@click.option("--group", "groups", multiple=True, type=click.Choice(GROUPS),
              help="Column group(s): published, as_printed (emulated listings), corrected (solver). Default all.")
@click.option("--quirk", "quirks", multiple=True, metavar="NAME=on|off",
              help="Toggle a listing error in the as-printed emulation (NAME may be 'all'); repeatable.")
@click.option("--diff/--no-diff", default=True, show_default=True, help="Print the differences between groups.")
@click.option("--walk", is_flag=True, help="Switch the quirks off one by one and print the max deviation from "
              "the corrected columns after each step.")
@click.option("--list-quirks", is_flag=True, help="List the quirk switches and the tables they affect.")
@click.option("--effects", is_flag=True,
              help="Markdown table of each quirk's measured effect (max change of dX, dY [in]).")
@click.option("--json", "as_json", is_flag=True,
              help='Print {"I": {"published": {...}, "as_printed": {...}, "corrected": {...}}, ...}.')
@click.option("--wide", is_flag=True, help="Groups side by side and every row of the differences (176 columns).")
def thesis(tables: tuple[str, ...], groups: tuple[str, ...], quirks: tuple[str, ...], diff: bool, walk: bool,
           list_quirks: bool, effects: bool, as_json: bool, wide: bool) -> None:
    """Reproduce the thesis's Tables I-III (Ali 1977): published, as printed, corrected."""
    q = _parse_quirks(quirks)
    tables = tables or TABLES
    groups = groups or GROUPS
    if list_quirks:
        for name in ThesisQuirks.names():
            used = ", ".join(t for t in TABLES if name in QUIRKS_BY_TABLE[t])
            click.echo(f"{name:38s} {'on ' if getattr(q, name) else 'off'}  tables {used}")
        return
    if effects:
        click.echo("| quirk | " + " | ".join(f"Table {t} off (src / cog)" for t in TABLES) + " | "
                   + " | ".join(f"Table {t} alone on (src / cog)" for t in TABLES) + " |")
        click.echo("|---" * (1 + 2 * len(TABLES)) + "|")
        for row in quirk_effects():
            cells = [_effect_cell(row[t], kind) for kind in ("off_from_printed", "on_from_corrected") for t in TABLES]
            click.echo(f"| `{row['quirk']}` | " + " | ".join(cells) + " |")
        return
    if walk:
        for t in tables:
            cor = corrected(t)
            click.echo(f"TABLE {t}: max |deviation from corrected| [in] as the quirks are switched off in turn")
            click.echo(f"  {'step':40s}{'source':>10}{'cognate':>10}")
            for name, tab in quirk_walk(t):
                if name != "as printed" and name not in QUIRKS_BY_TABLE[t]:
                    continue
                s = max(float(np.max(np.abs(tab.column(k) - cor.column(k)))) for k in TABLE_KEYS[3:5])
                c = max(float(np.max(np.abs(tab.column(k) - cor.column(k)))) for k in TABLE_KEYS[5:7])
                label = name if name == "as printed" else f"- {name}"
                click.echo(f"  {label:40s}{s:10.4f}{c:10.4f}")
        return
    if as_json:
        out = {t: {g: tab.as_dict() for g, tab in _groups(t, groups, q).items()} for t in tables}
        click.echo(json.dumps(out, indent=1))
        return
    if q.active() != ThesisQuirks().active():
        click.echo(f"as-printed quirks off: {', '.join(n for n in ThesisQuirks.names() if not getattr(q, n))}")
    for t in tables:
        mm = corrected_mass_model(t)
        click.echo((_render if wide else _render_narrow)(t, _groups(t, groups, q), diff))
        note = (f"  corrected: solve_quasi_static, mass model {mm.name!r} (payload {mm.payload:.6g} kg, "
                f"joint_split {mm.joint_split:g}, lumps {mm.lumps}, placement {mm.placement!r}), 300 rpm")
        click.echo(note + "\n" if wide else note.replace(", joint_split", ",\n  joint_split") + "\n")
