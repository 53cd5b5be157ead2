"""A fresh ``ked check`` process loads only what one check needs.

``scipy.linalg`` clones numpy's whole namespace for the array API when imported (it touches every lazy
numpy submodule: numpy.testing, numpy.f2py, ...): about 0.1 s of a 0.6 s distributed-model check, for one
triangular solve in the periodic solve's GMRES.  ``numpy.ma`` came with the first ``np.setdiff1d``.  The
check's path must reach neither (a module's presence, not a time, is asserted: the machine's load does not
matter).
"""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

PROBE = """
import json, sys
import ked_linear.periodic as periodic
from ked_cli.main import cli
factored = []
banded = periodic._banded_operator
periodic._banded_operator = lambda *a: factored.append(1) or banded(*a)
try:
    cli(["check", "--mass-model", sys.argv[1], "--rpm", sys.argv[2]], standalone_mode=False)
finally:
    print(json.dumps([sorted(m for m in ("scipy", "scipy.linalg", "scipy.sparse", "numpy.ma") if m in sys.modules),
                      len(factored)]))
"""


@pytest.mark.parametrize(("mass_model", "rpm"), [("distributed", "100"), ("distributed", "300"), ("joints", "100")])
def test_check_imports_no_scipy(mass_model: str, rpm: str) -> None:
    # distributed: the periodic solve goes through GMRES (its coordinates x harmonics exceed the dense
    # limit), at 300 rpm with the banded preconditioner (its block LU: once scipy.sparse's splu, 0.3 s of
    # imports); joints: the dense collocation and the full Floquet propagator
    out = subprocess.run([sys.executable, "-c", PROBE, mass_model, rpm], capture_output=True, text=True, cwd=ROOT,
                         check=True).stdout
    imported, factored = json.loads(out.strip().splitlines()[-1])
    assert imported == []
    if rpm == "300":  # the banded preconditioner was built (else this case would test nothing more)
        assert factored >= 1
