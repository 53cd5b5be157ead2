"""Meaningless input is refused at load, in one line, with exit status 2 and no traceback: through the
real command line (subprocesses), the TOML loader and the Python API alike.  Every refusal names the
parameter or file, what is wrong and what is allowed; the linkages and configs the project uses still load.
"""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from compare.config import ConfigError, check_speed, load_config, load_linkage, parse_config
from ked_quasi import rules
from ked_quasi.linkage import THESIS_SECTION, FourBar, Section, thesis_fourbar
from ked_quasi.massmodel import MassModel, default_payload
from ked_quasi.scene import variant

ROOT = Path(__file__).resolve().parents[1]
SECTION = """
[linkage.section]
youngs_modulus = 7.0e10
area = 1.0e-4
second_moment = 1.0e-9
density = 2700.0
"""
# links 0.12, 0.24, 0.12 m on a 0.24 m ground: a parallelogram, a change point at crank angle 0
CHANGE_POINT = """
[linkage]
crank = 0.12
coupler = 0.24
follower = 0.12
extender = 0.1
coupler_angle_deg = 30.0
ground = 0.24
""" + SECTION
# the thesis linkage (10, 30, 25, 30 in) with a 10 in = 0.254 m follower: s + l = p + q, a change point
THESIS_SHORT_FOLLOWER = """
[linkage]
crank = 0.254
coupler = 0.762
follower = 0.254
extender = 0.254
coupler_angle_deg = 60.0
ground = 0.762
""" + SECTION
QS = """
[campaign]
name = "refusals"
step_deg = 30.0
n_modes = 1
solvers = ["quasi_static"]
"""


def ked(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "ked_cli", *args], capture_output=True, text=True, cwd=cwd,
                          timeout=120)


def assert_refused(res: subprocess.CompletedProcess, *words: str) -> str:
    """Exit 2, exactly one line on stderr, no traceback, every word present; returns the line."""
    err = res.stderr.strip()
    assert res.returncode == 2, (res.returncode, res.stderr[-2000:], res.stdout[-500:])
    assert "Traceback" not in err and "Traceback" not in res.stdout, err
    assert len(err.splitlines()) == 1, err
    assert res.stdout.strip() == "", res.stdout[-500:]
    for w in words:
        assert w in err, (w, err)
    return err


def write(tmp_path: Path, name: str, text: str) -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


def near_toggle_follower(toggle_distance_deg: float) -> float:
    """Follower length [m] of the crank-rocker crank 0.2, coupler 0.8, ground 1 m whose transmission angle is
    180 deg - ``toggle_distance_deg`` at crank angle 180 deg (B-A-Q stretched: |AQ| = 1.2 m): the law of
    cosines d^2 = b^2 + f^2 - 2 b f cos(mu) solved for f.  At crank angle 0 (|AQ| = 0.8 m) mu is about 75 deg,
    so the toggle distance of the whole turn is the one at 180 deg."""
    b, d, mu = 0.8, 1.2, math.radians(180.0 - toggle_distance_deg)
    return b * math.cos(mu) + math.sqrt(b * b * math.cos(mu) ** 2 - b * b + d * d)


def near_toggle_fourbar(toggle_distance_deg: float, **kw) -> FourBar:
    return FourBar(crank=0.2, coupler=0.8, follower=near_toggle_follower(toggle_distance_deg), extender=0.2,
                   coupler_angle=0.5, sections=(THESIS_SECTION,) * 4, follower_pivot=(1.0, 0.0), **kw)


# -- change-point and near-change-point linkages -----------------------------------------------------


@pytest.mark.parametrize("command", ["quasi", "linear", "simulate", "check"])
def test_change_point_linkage_is_refused_by_every_single_scene_command(tmp_path, command):
    f = write(tmp_path, "change_point.toml", CHANGE_POINT)
    assert_refused(ked(command, "--linkage", str(f)), "--linkage", "change_point.toml",
                   "minimum transmission angle 0.00 deg", f"below {rules.MIN_TRANSMISSION_DEG:g} deg")


def test_thesis_with_short_follower_is_refused(tmp_path):
    f = write(tmp_path, "thesis_254.toml", THESIS_SHORT_FOLLOWER)
    assert_refused(ked("quasi", "--linkage", str(f), "--json"), "--linkage", "transmission angle 0.00 deg",
                   "follower=0.254 m")


def test_change_point_campaign_is_refused_at_dry_run(tmp_path):
    f = write(tmp_path, "cp_campaign.toml", QS + CHANGE_POINT + "[grid]\nrpm = [60.0]\n")
    assert_refused(ked("run", str(f), "--dry-run", "--out", str(tmp_path / "x.h5")), "cp_campaign.toml",
                   "linkage", "transmission angle")
    assert not (tmp_path / "x.h5").exists()


def test_change_point_api_fourbar_and_loaders_raise_value_error(tmp_path):
    with pytest.raises(ValueError, match=r"FourBar: minimum transmission angle 0\.00 deg .*follower=0\.254 m"):
        FourBar(crank=0.254, coupler=0.762, follower=0.254, extender=0.254, coupler_angle=1.0,
                sections=(THESIS_SECTION,) * 4, follower_pivot=(0.762, 0.0))
    with pytest.raises(ConfigError, match="transmission angle") as err:
        load_linkage(write(tmp_path, "cp.toml", CHANGE_POINT))
    assert err.value.problems[0].startswith("linkage:")
    with pytest.raises(ConfigError, match="transmission angle"):
        parse_config(QS + CHANGE_POINT)


@pytest.mark.parametrize("distance", [0.5, 9.0, 9.9])
def test_near_change_point_below_the_bound_is_refused_with_the_angle_found(distance):
    with pytest.raises(ValueError, match=rf"minimum transmission angle {distance:.2f} deg \(at crank angle 180\.0"):
        near_toggle_fourbar(distance)


@pytest.mark.parametrize("distance", [10.1, 11.0, 30.0])
def test_near_change_point_above_the_bound_is_accepted(distance):
    fb = near_toggle_fourbar(distance)
    found, at = fb.min_transmission_deg()
    # closed form (law of cosines at the stretched position, see near_toggle_follower)
    assert found == pytest.approx(distance, abs=1e-9) and at == pytest.approx(180.0)


def test_toggle_check_can_be_skipped_only_explicitly():
    fb = near_toggle_fourbar(1.0, check_toggle=False)  # what the solver-robustness tests use
    assert fb.min_transmission_deg()[0] == pytest.approx(1.0, abs=1e-9)
    assert "check_toggle" not in fb.to_dict()


# -- a linkage file without a [linkage] table --------------------------------------------------------


@pytest.mark.parametrize("text, found", [("[linkag]\ncrank = 0.1\n", "tables found: [linkag]"),
                                         ("[Linkage]\ncrank = 0.1\n", "tables found: [Linkage]"),
                                         ("", "no tables found"),
                                         ("crank = 0.1\n", "keys outside any table: crank")])
def test_linkage_file_without_linkage_table_is_refused_naming_the_tables(tmp_path, text, found):
    f = write(tmp_path, "mine.toml", text)
    assert_refused(ked("quasi", "--linkage", str(f)), "--linkage", "mine.toml", "no [linkage] table", found)


def test_linkage_file_without_linkage_table_api(tmp_path):
    with pytest.raises(ConfigError, match=r"no \[linkage\] table \(tables found: \[Linkage\]\)"):
        load_linkage(write(tmp_path, "x.toml", "[Linkage]\ncrank = 0.1\n"))


# -- values implausible in SI ------------------------------------------------------------------------


def test_length_in_millimetres_is_refused_naming_the_mix_up(tmp_path):
    text = CHANGE_POINT.replace("crank = 0.12", "crank = 50").replace("follower = 0.12", "follower = 0.2")
    f = write(tmp_path, "mm.toml", text)
    assert_refused(ked("quasi", "--linkage", str(f)), "--linkage", "linkage.crank = 50 m",
                   "lengths are in metres (50 mm = 0.05 m)", "(0, 10] m")
    with pytest.raises(ValueError, match=r"FourBar.crank = 50 m: lengths are in metres"):
        FourBar(crank=50.0, coupler=0.8, follower=0.5, extender=0.2, coupler_angle=0.5,
                sections=(THESIS_SECTION,) * 4, follower_pivot=(1.0, 0.0))
    with pytest.raises(ValueError, match=r"FourBar.ground \(\|follower_pivot - crank_pivot\|\) = 20 m"):
        FourBar(crank=0.2, coupler=0.8, follower=0.5, extender=0.2, coupler_angle=0.5,
                sections=(THESIS_SECTION,) * 4, follower_pivot=(20.0, 0.0))


def test_section_in_millimetres_is_refused_naming_the_mix_up(tmp_path):
    # a 12 mm square bar written in mm^2: 144, i.e. a section side of 12 m
    f = write(tmp_path, "area.toml", QS + "[linkage]\npreset = 'thesis'\n[linkage.section]\narea = 144.0\n")
    assert_refused(ked("run", str(f), "--dry-run", "--out", str(tmp_path / "x.h5")),
                   "linkage.section.area = 144 m^2", "areas are in m^2 (144 mm^2 = 0.000144 m^2)")
    with pytest.raises(ValueError, match="Section.second_moment = 1728 m\\^4: second moments are in m\\^4"):
        Section(youngs_modulus=7e10, area=1e-4, second_moment=1728.0, density=2700.0)


def test_speed_ratio_above_ten_is_refused_cli(tmp_path):
    # thesis, tip mass: omega1_min = 2 pi x 9.0 Hz, so 90 000 rpm is r ~ 166
    assert_refused(ked("quasi", "--rpm", "90000"), "--rpm", "90000", "speed ratio r", "above 10", "rev/min")
    assert_refused(ked("check", "--rpm", "300", "--rpm", "90000"), "--rpm", "speed ratio r", "above 10")
    f = write(tmp_path, "fast.toml", QS + "[grid]\nrpm = [300.0, 60000.0]\n")
    assert_refused(ked("run", str(f), "--dry-run", "--out", str(tmp_path / "x.h5")), "grid.rpm", "= 60000",
                   "speed ratio r", "above 10")


def test_speed_ratio_bound_api_and_the_thesis_speed_is_accepted():
    fb = thesis_fourbar()
    tip = MassModel("tip", payload=default_payload("tip"))
    check_speed(fb, tip, 300.0, 10.0)  # the thesis speed, r ~ 0.55
    with pytest.raises(ValueError, match="speed ratio r = Omega/omega1_min = .* above 10"):
        check_speed(fb, tip, 90000.0, 10.0)
    with pytest.raises(ConfigError, match="grid.rpm"):
        parse_config(QS + "[grid]\nrpm = [60000.0]\n")


def test_speed_ratio_is_checked_at_the_softest_stiffness_scale():
    # every Young's modulus x k scales the frozen stiffness by k: omega1_min grows exactly as sqrt(k)
    from compare.config import _omega1_min

    fb, tip = thesis_fourbar(), MassModel("tip", payload=default_payload("tip"))
    assert _omega1_min(fb.with_stiffness_scale(4.0), tip, 30.0) == pytest.approx(
        2.0 * _omega1_min(fb, tip, 30.0), rel=1e-9)
    # so the softest scale of the grid decides: r ~ 0.55 at k = 1 is ~550 at k = 1e-6
    with pytest.raises(ConfigError, match=r"grid.rpm \(source, tip, stiffness x1e-06\) = 300: speed ratio"):
        parse_config(QS + "[grid]\nrpm = [300.0]\nstiffness_scales = [1.0, 1e-6]\n")


def test_speed_ratio_refusal_uses_the_exact_omega1_min():
    """The load-time screen refuses only on the omega1_min the run itself computes: a speed just below
    r = 10 passes, one just above is refused."""
    from compare.execute import frame

    # 20 lumps: the quick screen (8 lumps, 30 deg) differs from the run's omega1_min; the refusal uses the latter
    text = QS + "[grid]\nmass_models = [{ name = 'distributed', lumps = 20 }]\nspeed_ratios = [1.0]\n"
    (spec,) = parse_config(text).scenes()
    omega1 = frame(spec).omega1_min
    rpm10 = 10.0 * omega1 * 60.0 / (2.0 * math.pi)
    fb, mm = spec.fourbar(), spec.mass_model
    check_speed(fb, mm, 0.999 * rpm10, 30.0)
    with pytest.raises(ValueError, match="above 10"):
        check_speed(fb, mm, 1.001 * rpm10, 30.0)


# -- numbers, names, grid size, speed lists ----------------------------------------------------------


@pytest.mark.parametrize("value", ["nan", "inf", "1e400", "-inf"])
def test_non_finite_lumps_are_refused(value):
    assert_refused(ked("quasi", "--mass-model", "distributed", "--lumps", value), "--lumps", "[1, 256]")


def test_quoted_numbers_are_refused_in_toml(tmp_path):
    f = write(tmp_path, "quoted.toml", QS + "[grid]\nrpm = [\"60\"]\n")
    assert_refused(ked("run", str(f), "--dry-run", "--out", str(tmp_path / "x.h5")), "grid.rpm[0]",
                   "got the string '60'")
    with pytest.raises(ValueError, match="string"):
        rules.RPM.check("60")
    with pytest.raises(ValueError, match="FourBar.crank"):
        FourBar(crank="0.2", coupler=0.8, follower=0.5, extender=0.2, coupler_angle=0.5,
                sections=(THESIS_SECTION,) * 4, follower_pivot=(1.0, 0.0))


def test_campaign_name_with_nul_is_refused_at_dry_run(tmp_path):
    f = write(tmp_path, "name.toml", QS.replace('name = "refusals"', 'name = "a\\u0000b"') + "[grid]\nrpm = [60.0]\n")
    assert_refused(ked("run", str(f), "--dry-run", "--out", str(tmp_path / "x.h5")), "campaign.name",
                   "control characters", "'a\\x00b'")


@pytest.mark.parametrize("name", ["tab\\there", "new\\nline", "   ", "del\\u007f"])
def test_campaign_name_with_control_characters_is_refused_api(name):
    with pytest.raises(ConfigError, match="campaign.name: must be non-blank text without control characters"):
        parse_config(QS.replace('name = "refusals"', f'name = "{name}"') + "[grid]\nrpm = [60.0]\n")


def test_huge_grid_is_refused_at_load(tmp_path):
    rpms = ", ".join(f"{1 + i}" for i in range(2000))
    scales = ", ".join(f"{1 + i * 0.001:g}" for i in range(3200))
    f = write(tmp_path, "huge.toml", QS + f"[grid]\nrpm = [{rpms}]\nstiffness_scales = [{scales}]\n")
    assert_refused(ked("run", str(f), "--dry-run", "--out", str(tmp_path / "x.h5")), "grid",
                   "6400000 scenes", f"({rules.MAX_SCENES})", "split the grid")


def test_grid_at_the_cap_is_accepted():
    n = rules.MAX_SCENES // 100
    text = QS + "[grid]\nrpm = [" + ", ".join(f"{1 + i}" for i in range(n)) + "]\n" + \
        "stiffness_scales = [" + ", ".join(f"{1 + i * 0.01:g}" for i in range(100)) + "]\n"
    assert parse_config(text).grid.size() == rules.MAX_SCENES


def test_equal_rpm_range_is_refused():
    assert_refused(ked("check", "--rpm-range", "60:60:3"), "--rpm-range", "60:60:3", "equal speeds")


# -- what the project uses still loads ---------------------------------------------------------------


def test_thesis_linkage_and_its_cognate_are_accepted():
    for mech in ("source", "cognate"):
        mu, _ = variant(thesis_fourbar(), mech).min_transmission_deg()
        # thesis: |AQ| in [20, 40] in, cos mu = (30^2 + 25^2 - 20^2) / (2 30 25) = 0.75 at crank angle 0
        assert mu == pytest.approx(math.degrees(math.acos(0.75)), abs=1e-9)


COMMITTED = sorted({*(ROOT / "results" / "studies").glob("*.toml"), *(ROOT / "results" / "studies" / "stability").glob(
    "*.toml"), ROOT / "results" / "reference" / "reference.toml", ROOT / "compare" / "default_campaign.toml"})
# refused on purpose: the stability study's cases past the Grashof limit and at / next to a toggle
REFUSED = {"05_near_toggle.toml": "transmission angle", "06_change_point.toml": "transmission angle",
           "07_cannot_assemble.toml": "cannot assemble"}


@pytest.mark.parametrize("path", COMMITTED, ids=[p.name for p in COMMITTED])
def test_committed_configs_still_load(path):
    if path.name in REFUSED:
        with pytest.raises(ConfigError, match=REFUSED[path.name]):
            load_config(path)
        return
    assert load_config(path).scenes()


def test_atlas_linkages_are_above_the_bound():
    """The atlas keeps linkages (and cognates) at least its own sampling bound from a toggle, which is at
    least the loader's: every committed atlas linkage is accepted."""
    from ked_research.atlas.generate import RANGES

    assert RANGES.min_transmission_deg >= rules.MIN_TRANSMISSION_DEG
    with h5py.File(ROOT / "results" / "atlas" / "atlas.h5", "r") as f:
        for name in ("linkages/min_transmission_deg", "linkages/cognate_min_transmission_deg"):
            mu = np.asarray(f[name][()], dtype=float)
            assert np.nanmin(mu) >= rules.MIN_TRANSMISSION_DEG, name


@pytest.mark.parametrize("preset", ["thesis", "simeon"])
@pytest.mark.parametrize("solvers", ['["quasi_static"]', '["quasi_static", "linear"]'])
def test_a_scene_too_large_to_solve_is_refused_at_load(preset, solvers):
    # 36000 crank angles x 256 lumps per link exceeds the work bound of ked_quasi.rules.check_work (angles x
    # coordinates^2 > 4e8) for either kind: refused when the file is read, one line naming both parameters,
    # whatever the solvers (it used to fail at run time, or as an internal error with the linear model)
    text = f"""
[linkage]
preset = "{preset}"
[grid]
mass_models = [{{name = "distributed", lumps = 256}}]
rpm = [300]
[campaign]
solvers = {solvers}
step_deg = 0.01
"""
    with pytest.raises(ConfigError) as exc:
        parse_config(text)
    (problem,) = exc.value.problems
    assert problem.startswith("campaign.step_deg: with grid.mass_models[0].lumps = 256: ")
    assert "too large a problem" in problem
