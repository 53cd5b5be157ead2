"""The schema of a campaign file's tables and scene arrays: every column and array with its units and
description (written into the file beside it; ``docs/hdf5_schema.md`` states the layout).
"""

from __future__ import annotations

# The metric columns: one row per (solver pair, component); version 4 in ``/metric_table`` (with the scene's
# key), version 3 in one compound dataset ``metrics`` per scene.  name, version-3 HDF5 type, units ("row" =
# the row's ``units`` column; "1" dimensionless, "" text), description.
METRIC_FIELDS: tuple[tuple[str, str, str, str], ...] = (
    ("solver", "S32", "", "solver measured"),
    ("reference", "S32", "", "reference solver (the higher fidelity)"),
    ("component", "S16", "", "dx, dy, rotation, vector (the deflection vector (dx, dy)), or stress_<link> (the "
                             "link's extreme-fibre normal stresses, both fibres; holds = the link's stress verdict)"),
    ("units", "S8", "", "units of the component"),
    ("history_error", "f8", "1", "max|a - b| / max|b| over the cycle"),
    ("peak_error", "f8", "1", "|max|a| - max|b|| / max|b|"),
    ("max_abs_error", "f8", "row", "max|a - b|"),
    ("rms_error", "f8", "row", "root mean square of |a - b|"),
    ("phase_shift_rad", "f8", "rad", "time lag of the reference's peak behind the solver's, (-pi, pi]"),
    ("amplification", "f8", "1", "max|b| / max|a|"),
    ("solver_peak", "f8", "row", "max|a|"),
    ("reference_peak", "f8", "row", "max|b|"),
    ("holds", "u1", "1", "1 if this component's history_error < tolerance"),
    ("pair_holds", "u1", "1", "1 if the pair holds (the verdict): verdict_error < tolerance; the rotation never "
                              "enters it"),
    ("verdict_error", "f8", "1", "the verdict's measure: history error of the deflection vector (dx, dy), "
                                 "max_k |a_k - b_k| / max_k |b_k| (the pair's vector row's history_error; of dx "
                                 "or dy alone where only one is stored)"),
    ("omega_rad_s", "f8", "rad/s", "crank speed"),
    ("omega1_min_rad_s", "f8", "rad/s", "lowest first natural circular frequency over the cycle"),
    ("speed_ratio", "f8", "1", "omega / omega1_min"),
    ("tolerance", "f8", "1", "campaign tolerance of the verdict"),
)


SCENES = "scenes"


RUNS = "runs"


SCENE_TABLE = "scene_table"


SOLUTION_TABLE = "solution_table"


METRIC_TABLE = "metric_table"


TABLES = (RUNS, SCENE_TABLE, SOLUTION_TABLE, METRIC_TABLE)


ARRAYS: dict[str, tuple[str, str]] = {
    "crank_angle": ("rad", "crank angle grid, CCW from M->Q, 0 .. 360 deg - step (n,)"),
    "coupler_point": ("m", "rigid coupler point P (x, y), global frame (n, 2)"),
    "natural_frequencies": ("Hz", "first n_modes natural frequencies of the frozen structure at each crank angle "
                                  "(n, n_modes)"),
}
"""Per-scene arrays besides the solutions: name -> (units, description)."""


SCENE_COLUMNS: dict[str, tuple[str, str]] = {
    "key": ("", "content key: first 16 hex digits of SHA-256 of json without solvers"),
    "label": ("", "readable label of the scene"),
    "status": ("", "ok or failed"),
    "stage": ("", "first failing stage: '', setup, a solver's name, metrics, worker"),
    "error_type": ("", "exception type of the failure"),
    "message": ("", "message of the failure"),
    "warnings": ("", "solver warnings, '; '-joined"),
    "failure_class": ("", "'', numerical, physical, undecided, input"),
    "rpm": ("rev/min", "resolved crank speed"),
    "omega1_min_rad_s": ("rad/s", "lowest first natural circular frequency over the cycle"),
    "run": ("1", "row of /runs of the run that stored the scene"),
    "json": ("", "canonical JSON of the scene's parameters (the key is hashed from it without solvers)"),
    "mechanism": ("", "source or cognate"),
    "mass_model": ("", "mass model name"),
    "mass_lumps": ("1", "lumps per link"),
    "payload_kg": ("kg", "payload mass"),
    "joint_split": ("1", "share of a link's mass lumped at its first joint"),
    "lump_placement": ("", "midpoint or end"),
    "speed_kind": ("", "rpm or ratio: how the speed was given"),
    "speed_rpm": ("rev/min", "crank speed as given (NaN when given as a ratio)"),
    "speed_ratio_requested": ("1", "Omega / omega1_min as given (NaN when given in rpm)"),
    "stiffness_scale": ("1", "Young's modulus multiplier"),
    "damping_ratio": ("1", "modal damping ratio"),
    "direction": ("", "ccw or cw"),
    "step_deg": ("deg", "crank-angle step"),
    "n_modes": ("1", "natural frequencies stored per crank angle"),
    "outputs": ("", "stored components, comma-separated"),
    "solvers": ("", "solvers the scene runs, comma-separated"),
    "tolerance": ("1", "verdict tolerance"),
    "kind": ("", "linkage kind: four-bar or slider-crank"),
    "offset_m": ("m", "slider-crank: offset of the slider line from the crank pivot"),
    "coupler_point_fraction": ("1", "slider-crank: coupler point P as a fraction of the coupler from A"),
    "slider_mass_kg": ("kg", "slider-crank: lumped slider mass"),
    "rigid": ("", "slider-crank: rigid flag per link (links order), comma-separated"),
    "crank_m": ("m", "crank length"),
    "coupler_m": ("m", "coupler length"),
    "follower_m": ("m", "follower length"),
    "extender_m": ("m", "extender length (B to P)"),
    "coupler_angle_rad": ("rad", "angle from AB to AP, CCW"),
    "crank_pivot_m": ("m", "crank pivot M (x, y)"),
    "follower_pivot_m": ("m", "follower pivot Q (x, y)"),
    "branch": ("", "assembly branch"),
    "links": ("", "order of the per-link columns"),
    "youngs_modulus_Pa": ("Pa", "Young's modulus per link (links order)"),
    "area_m2": ("m^2", "cross-section area per link"),
    "second_moment_m4": ("m^4", "second moment of area per link"),
    "density_kg_m3": ("kg/m^3", "density per link"),
    "frequencies_wall_s": ("s", "wall time of the natural frequencies"),
    "total_wall_s": ("s", "wall time of the scene"),
    "worker": ("", "host:pid that computed the scene"),
    "finished_utc": ("", "ISO 8601 time the scene finished"),
    "complete": ("1", "1: the scene is complete (its row is written after its arrays and its other rows)"),
}


SOLUTION_COLUMNS: dict[str, tuple[str, str]] = {
    "key": ("", "scene key"),
    "solver": ("", "solver name; histories in /scenes/<key>/solutions/<solver>"),
    "status": ("", "ok or failed"),
    "message": ("", "message of the failure"),
    "error_type": ("", "exception type of the failure"),
    "failure_class": ("", "'', numerical, physical, undecided, input"),
    "flags": ("", "validity flags, comma-separated: the answer is outside the range where the model holds"),
    "warnings": ("", "solver warnings"),
    "fidelity": ("1", "fidelity rank of the solver (higher = reference)"),
    "settings_json": ("", "resolved settings (JSON)"),
    "stats_json": ("", "wall_s [s] and the solver's own statistics (JSON)"),
}


METRIC_COLUMNS: dict[str, tuple[str, str]] = {
    "key": ("", "scene key"), **{name: (units, description) for name, _, units, description in METRIC_FIELDS}}


RUN_COLUMNS: dict[str, tuple[str, str]] = {
    "run": ("1", "run number (the scenes' run column)"),
    "started_utc": ("", "ISO 8601 start time"),
    "campaign_name": ("", "campaign name"),
    "campaign_config": ("", "TOML text of the campaign"),
    "n_scenes": ("1", "scenes the run planned"),
    "harness_version": ("", "version of ked-harness that ran"),
    "exudyn_version": ("", "version of Exudyn"),
    "numpy_version": ("", "version of numpy"),
    "h5py_version": ("", "version of h5py"),
    "hdf5_version": ("", "version of the HDF5 library"),
    "python_version": ("", "version of Python"),
    "git_commit": ("", "commit of the harness source ('' outside a git checkout)"),
    "host": ("", "machine that ran"),
}
