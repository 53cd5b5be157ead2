"""The thesis's Tables I-III: transcription, as-printed emulation, typos, quirk switches, corrected solver."""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner

from ked_cli.thesis import thesis
from ked_quasi.thesis import (
    QUIRKS_BY_TABLE,
    ThesisQuirks,
    as_printed,
    corrected,
    published_table,
    quirk_walk,
)
from ked_quasi.thesis_tables import COLUMNS, TABLE_KEYS, TABLES, TYPOS, is_typo, published

DEFLECTIONS = ("source_dx_in", "source_dy_in", "cognate_dx_in", "cognate_dy_in")
RIGID = ("x_in", "y_in")
TOL_DEFLECTION = 0.001  # in
TOL_RIGID = 0.0005  # in


@pytest.fixture(scope="module")
def printed() -> dict:
    return {t: as_printed(t) for t in TABLES}


@pytest.fixture(scope="module")
def solver() -> dict:
    return {t: corrected(t) for t in TABLES}


def test_transcription_shape_and_sources():
    for t in TABLES:
        tab = published(t)
        assert tab.columns["crank_angle_deg"].tolist() == list(range(0, 361, 20))
        assert set(tab.columns) == set(COLUMNS)
        assert np.all(np.diff(tab.line) == 1) and tab.page in (50, 51, 52)
        assert tab.column("x_in").size == 18  # rows 0-340
    # spot checks against the scan
    assert published("I").value("source_dx_in", 20.0) == -2.255
    assert published("II").value("cognate_dy_in", 300.0) == 0.102
    assert published("III").value("source_dy_in", 0.0) == -0.090
    assert published("III").source_line(340.0) == 869


@pytest.mark.parametrize("table", TABLES)
def test_as_printed_reproduces_published_deflections(printed, table):
    pub = published_table(table)
    for key in DEFLECTIONS:
        for deg, a, p in zip(pub.crank_angle_deg, printed[table].column(key), pub.column(key)):
            if not is_typo(table, float(deg), key):
                assert abs(a - p) <= TOL_DEFLECTION, f"Table {table} {key} at {deg:g} deg: {a:.4f} vs printed {p}"


@pytest.mark.parametrize("table", TABLES)
def test_as_printed_reproduces_published_rigid_path(printed, table):
    pub = published_table(table)
    for key in RIGID:
        for deg, a, p in zip(pub.crank_angle_deg, printed[table].column(key), pub.column(key)):
            if not is_typo(table, float(deg), key):
                assert abs(a - p) <= TOL_RIGID, f"Table {table} {key} at {deg:g} deg: {a:.4f} vs printed {p}"


def test_typos_are_misprints_with_reasons(printed):
    for ty in TYPOS:
        assert len(ty.reason) > 20 and ty.table in TABLES
        assert published(ty.table).value(ty.column, ty.angle_deg) == ty.printed
        if ty.column in TABLE_KEYS and ty.angle_deg <= 340:
            i = int(np.flatnonzero(printed[ty.table].crank_angle_deg == ty.angle_deg)[0])
            value = printed[ty.table].column(ty.column)[i]
            tol = TOL_RIGID if ty.column in RIGID else TOL_DEFLECTION
            assert abs(value - ty.printed) > 2 * tol  # really off, beyond the tolerance
            assert abs(value - ty.expected) <= TOL_RIGID  # the listing gives the corrected entry
        else:  # K.E.D.-mode columns: rigid coordinate + deflection
            tab = published(ty.table)
            axis = "x" if "_x_" in ty.column else "y"
            mech = ty.column.split("_")[0]
            total = tab.value(f"{axis}_in", ty.angle_deg) + tab.value(f"{mech}_d{axis}_in", ty.angle_deg)
            if ty.angle_deg == 360.0 and abs(total - ty.printed) < 1e-9:
                continue
            assert abs(total - ty.printed) > 0.002


@pytest.mark.parametrize("table", TABLES)
def test_all_quirks_off_equals_corrected_solver(solver, table):
    emu = as_printed(table, ThesisQuirks.none())
    cor = solver[table]
    for key in TABLE_KEYS[1:]:
        a, b = emu.column(key), cor.column(key)
        assert np.max(np.abs(a - b)) <= 1e-12 * np.max(np.abs(b)), key


@pytest.mark.parametrize("name", ThesisQuirks.names())
def test_each_quirk_is_live(printed, name):
    """Each switch alone changes the published-side result, and alone re-enabled changes the corrected one."""
    for start, flip in ((ThesisQuirks(), ThesisQuirks().without(name)),
                        (ThesisQuirks.none(), ThesisQuirks.none().with_(**{name: True}))):
        changes = []
        for t in QUIRKS_BY_TABLE:
            if name not in QUIRKS_BY_TABLE[t]:
                continue
            a = printed[t] if start == ThesisQuirks() else as_printed(t, start)
            b = as_printed(t, flip)
            changes.append(max(np.max(np.abs(a.column(k) - b.column(k))) for k in TABLE_KEYS[1:]))
        assert max(changes) > 1e-9, f"{name} changes nothing from {'all on' if start == ThesisQuirks() else 'all off'}"


@pytest.mark.parametrize("table", TABLES)
def test_quirks_outside_a_table_do_not_touch_it(printed, table):
    others = [n for n in ThesisQuirks.names() if n not in QUIRKS_BY_TABLE[table]]
    t = as_printed(table, ThesisQuirks().without(*others))
    for key in TABLE_KEYS:
        np.testing.assert_array_equal(t.column(key), printed[table].column(key))


@pytest.mark.parametrize("table", TABLES)
def test_quirk_walk_ends_at_corrected(solver, table):
    walk = quirk_walk(table)
    assert walk[0][0] == "as printed" and len(walk) == len(ThesisQuirks.names()) + 1
    last = walk[-1][1]
    for key in TABLE_KEYS[1:]:
        np.testing.assert_allclose(last.column(key), solver[table].column(key), rtol=0, atol=1e-12)


def test_quirks_api():
    q = ThesisQuirks()
    assert all(getattr(q, n) for n in q.names()) and not ThesisQuirks.none().active()
    assert not q.without("g1_cos").g1_cos
    with pytest.raises(ValueError, match="unknown quirk"):
        q.with_(no_such_quirk=False)
    with pytest.raises(ValueError, match="table"):
        as_printed("IV")


def test_cli_json_keys():
    out = CliRunner().invoke(thesis, ["--json"])
    assert out.exit_code == 0, out.output
    data = json.loads(out.output)
    assert list(data) == ["I", "II", "III"]
    for t in data.values():
        assert list(t) == ["published", "as_printed", "corrected"]
        for g in t.values():
            assert list(g) == list(TABLE_KEYS) and all(len(v) == 18 for v in g.values())
    assert data["I"]["published"]["source_dx_in"][1] == -2.255


def test_cli_text_and_quirk_toggle():
    runner = CliRunner()
    out = runner.invoke(thesis, ["--table", "II", "--quirk", "load_sign_plus=off"])
    assert out.exit_code == 0, out.output
    assert "TABLE II" in out.output and "load_sign_plus" in out.output
    bad = runner.invoke(thesis, ["--quirk", "nonsense=off"])
    assert bad.exit_code != 0
    walk = runner.invoke(thesis, ["--walk", "--table", "III"])
    assert walk.exit_code == 0 and "case3_block_diagonal_beta" in walk.output


def test_cli_fits_a_100_column_terminal_and_wide_keeps_every_number():
    runner = CliRunner()
    narrow, wide = runner.invoke(thesis, []), runner.invoke(thesis, ["--wide"])
    assert narrow.exit_code == 0 and wide.exit_code == 0
    assert max(len(line) for line in narrow.output.splitlines()) <= 100
    # every table entry (published, as printed, corrected; three groups side by side in --wide) is printed
    def entries(text: str, bars: int) -> list[str]:
        return sorted(tok for line in text.splitlines() if line[:5].strip().isdigit() and line.count("|") == bars
                      for tok in line.split("|", 1)[1].replace("|", " ").split())

    assert len(entries(wide.output, 3)) == 3 * 18 * 6 * 3 and entries(wide.output, 3) == entries(narrow.output, 1)


def test_errata_effects_table_is_current():
    """results/thesis_errata.md's effects table is exactly what `ked thesis --effects` prints now."""
    from pathlib import Path

    out = CliRunner().invoke(thesis, ["--effects"])
    assert out.exit_code == 0, out.output
    doc = (Path(__file__).resolve().parents[1] / "results" / "thesis_errata.md").read_text()
    for line in out.output.strip().splitlines():
        assert line in doc, f"errata table out of date: {line}"
