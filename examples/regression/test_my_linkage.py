"""A user's regression test on agreement tolerances (run: pytest examples/regression).

The campaign my_linkage.toml runs into a fresh file; its verdicts must meet the expectations, and every answer
must agree with the stored baseline within the tolerances (the defaults, or the [tolerances] table of the
config).  After an intended change: pytest examples/regression --ked-regen (refreshes baseline/my_linkage.h5).
"""

from pathlib import Path

from ked_pytest import assert_agreement

HERE = Path(__file__).resolve().parent
CONFIG = HERE / "my_linkage.toml"


def test_quasi_static_holds_at_low_speed(ked_campaign):
    new = ked_campaign.run(CONFIG)
    assert_agreement(new, holds_below_speed_ratio=0.08, fails=["source/tip/1200rpm/k1/z0.02/ccw"])


def test_matches_baseline(ked_campaign, ked_baseline):
    new = ked_campaign.run(CONFIG)
    ked_baseline(new, HERE / "baseline" / "my_linkage.h5", tolerances=CONFIG)
