"""Every study regenerates its committed outputs byte for byte from the committed HDF5 files.

Expected values: the committed ``results/README.md`` and ``results/figures/*.png`` themselves (each was written
by ``ked study <name> --report-only`` from the same stored files).  This is a regeneration test, not a physics
test: a change of code that alters any published sentence, number or figure fails here and must regenerate and
commit them (``ked study <name> --report-only``), so the published results never drift from the code.

The studies run through the real command into a copy of the results directory.  Two things differ by design:
the study configs are read from the checkout (``results/studies/*.toml``), so a copy names them by a relative
path to the checkout (normalised back here); and a figure is compared byte for byte only when the installed
matplotlib is the one that wrote it (its PNG ``Software`` field): another version draws other bytes.
"""
from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import matplotlib
import pytest

from compare.sections import replace_section

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "results"
QUICK = ("stability", "stress", "work-precision")
SLOW = ("validity", "tiers", "atlas")
SECTIONS = {"stability": "stability", "stress": "stress", "work-precision": "work-precision", "validity": "validity",
            "tiers": "tiers", "atlas": "atlas"}
"""Each study's section of results/README.md (its <!-- BEGIN name --> ... <!-- END name --> markers)."""
FIGURES = {"stability": (), "stress": ("stress_limits",), "work-precision": ("work_precision", "work_precision_lumps"),
           "validity": ("validity_amplification", "validity_error", "validity_histories", "validity_rule",
                        "validity_variants"),
           "tiers": ("tiers_error_parts",),
           "atlas": ("atlas_confirm", "atlas_coupler_curves", "atlas_features", "atlas_limits", "atlas_map",
                     "atlas_prediction", "atlas_threshold")}


@pytest.fixture(scope="module")
def results_copy(tmp_path_factory) -> Path:
    """A copy of the committed results directory (HDF5 files, configs, README; no figures)."""
    out = tmp_path_factory.mktemp("regen") / "results"
    out.mkdir()
    for name in ("studies", "atlas"):
        shutil.copytree(RESULTS / name, out / name)
    shutil.copy2(RESULTS / "README.md", out / "README.md")
    return out


def _software(png: Path) -> str | None:
    """The PNG's ``Software`` text chunk (matplotlib writes its version there)."""
    found = re.search(rb"tEXtSoftware\x00([^\x00]*?), https", png.read_bytes()[:4096])
    return found.group(1).decode("latin-1") if found else None


def _regenerate(name: str, results: Path) -> None:
    # the study's section emptied first: a study that no longer writes its section fails too
    readme_path = results / "README.md"
    readme_path.write_text(replace_section(readme_path.read_text(encoding="utf-8"), SECTIONS[name], ""),
                           encoding="utf-8")
    proc = subprocess.run([sys.executable, "-m", "ked_cli", "study", name, "--report-only",
                           "--results-dir", str(results)], capture_output=True, text=True, timeout=1800)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "Traceback" not in proc.stderr
    readme = (results / "README.md").read_text(encoding="utf-8")
    # the configs are the checkout's: a copy of the results directory names them by a path to it
    readme = readme.replace(f"`{os.path.relpath(RESULTS, results)}/", "`")
    committed = (RESULTS / "README.md").read_text(encoding="utf-8")
    assert readme == committed, f"ked study {name} --report-only changed results/README.md"
    for fig in FIGURES[name]:
        new, old = results / "figures" / f"{fig}.png", RESULTS / "figures" / f"{fig}.png"
        assert new.is_file(), f"{fig}.png not drawn"
        if _software(old) != f"Matplotlib version{matplotlib.__version__}":
            continue  # another matplotlib draws other bytes: the sentence check above still holds
        assert new.read_bytes() == old.read_bytes(), f"ked study {name} --report-only changed {fig}.png"


@pytest.mark.parametrize("name", QUICK)
def test_quick_study_regenerates_byte_for_byte(name, results_copy):
    _regenerate(name, results_copy)


@pytest.mark.slow
@pytest.mark.parametrize("name", SLOW)
def test_study_regenerates_byte_for_byte(name, results_copy):
    _regenerate(name, results_copy)


def test_the_figure_lists_are_every_committed_figure():
    # the regeneration covers every figure the studies publish (a new figure joins FIGURES); the one other
    # committed figure is the Simeon benchmark's (`ked benchmark simeon --figure`, computed, not a report)
    listed = {f for figs in FIGURES.values() for f in figs}
    committed = {p.stem for p in (RESULTS / "figures").glob("*.png")}
    assert committed - listed == {"slider_validity"}
