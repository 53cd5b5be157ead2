"""compare: campaigns that run every registered solver on the same scenes, store and compare them.

The public campaign API (each ``ked`` campaign command is one of these calls)::

    from compare import load_config, run_campaign, read_scenes, verify, write_figures
    cfg = load_config("campaign.toml")            # or None: the default campaign
    summary = run_campaign(cfg, "out.h5", workers=2)
    results = read_scenes("out.h5")               # SceneResult per scene: solutions, metrics, verdict
    problems = verify("out.h5")                   # [] for a valid file
    write_figures(results, "out_figures")
    res = open_results("out.h5")                  # labelled data (extra ked-harness[xarray]): xarray, pandas

Names are imported on first use, so importing a submodule stays cheap.
"""

from __future__ import annotations

import importlib
from typing import Any

_API = {
    "load_config": "compare.config", "parse_config": "compare.config", "ConfigError": "compare.config",
    "CampaignConfig": "compare.config", "load_linkage": "compare.config",
    "run_campaign": "compare.runner", "run_scenes": "compare.runner", "plan": "compare.runner",
    "CampaignSummary": "compare.runner",
    "read_scenes": "compare.store", "verify": "compare.store", "StoreError": "compare.store",
    "SceneResult": "compare.results", "SceneSpec": "compare.scenes",
    "write_figures": "compare.figure_dir", "summary_row": "compare.inspect", "format_table": "compare.inspect",
    "open_results": "compare.labelled", "Results": "compare.labelled",
    "register": "compare.solvers", "Solver": "compare.solvers", "Solution": "compare.solvers",
}
__all__ = sorted(_API)


def __getattr__(name: str) -> Any:
    if name in _API:
        return getattr(importlib.import_module(_API[name]), name)
    raise AttributeError(f"module 'compare' has no attribute {name!r}")
