"""How large a scene the linear KED model takes: :data:`ked_linear.result.MAX_COORDINATES` elastic
coordinates (its memory grows as their square times the Floquet steps).  A command that needs the linear
model checks the scene's lumps per link against that cap when it loads its input, before any other solve."""

from __future__ import annotations

from dataclasses import replace

from ked_quasi import rules

from .result import MAX_COORDINATES


def elastic_size(scene: object) -> int:
    """Elastic coordinates of the linear model of a ``scene`` of any kind (no frame solve)."""
    from .kinds import model

    return model(scene).elastic_coordinates(scene)


def max_lumps(scene: object) -> int:
    """The most lumps per link (within the rules' range) whose linear model fits :data:`MAX_COORDINATES`,
    for the linkage and mass model of ``scene``; 0 when even one lump does not fit."""
    lo, hi = int(rules.LUMPS.lo), int(rules.LUMPS.hi)  # type: ignore[arg-type]

    def fits(n: int) -> bool:
        return elastic_size(replace(scene, mass_model=replace(scene.mass_model, lumps=n))) <= MAX_COORDINATES  # type: ignore[type-var, attr-defined]

    if not fits(lo):
        return 0
    while lo < hi:  # the size grows with the lumps: bisect for the last one that fits
        mid = (lo + hi + 1) // 2
        lo, hi = (mid, hi) if fits(mid) else (lo, mid - 1)
    return lo


def check_size(scene: object, label: str = "lumps") -> None:
    """Refuse (ValueError naming ``label`` and the allowed range) a scene the linear model cannot take."""
    size = elastic_size(scene)
    if size <= MAX_COORDINATES:
        return
    lumps = scene.mass_model.lumps  # type: ignore[attr-defined]
    most = max_lumps(scene)
    allowed = f"1..{most} for this linkage and mass model" if most else "none fits: use another mass model"
    raise ValueError(f"{label}: {lumps} lumps per link give the linear KED model {size} elastic coordinates, "
                     f"above its cap of {MAX_COORDINATES} (its memory grows as their square times the Floquet "
                     f"steps); allowed: {allowed}")
