"""The progress bar of every long command (``ked run``, ``ked check``, ``ked plot``): tqdm on stderr,
only when stderr is a terminal, shown once the work has run :data:`DELAY_S` and then kept ticking (its
elapsed time) even while one long step runs; cleared at the end."""

from __future__ import annotations

import sys
import threading
import time
from typing import Any

DELAY_S = 2.0
"""Work running longer than this shows its progress bar [s]."""
TICK_S = 1.0
"""How often a shown bar is redrawn while no step ends [s]."""


class NoBar:
    """The progress bar's interface, doing nothing (not a terminal, or no bar asked for)."""

    def __init__(self, total: int = 0):
        self.n, self.total = 0, total

    def __enter__(self) -> NoBar:
        return self

    def __exit__(self, *exc: object) -> None:
        return None

    def update(self, n: int = 1) -> None:
        self.n += n

    def refresh(self) -> None:
        return None

    def close(self) -> None:
        return None

    def set_postfix(self, *args: Any, **kw: Any) -> None:
        return None

    def set_postfix_str(self, text: str, refresh: bool = True) -> None:
        return None


def on_terminal() -> bool:
    """Whether stderr is a terminal (a bar is drawn only there)."""
    return hasattr(sys.stderr, "isatty") and sys.stderr.isatty()


def due(bar: Any) -> bool:
    """True once ``bar`` has run its delay: tqdm draws a bar at once on a refresh, so short work would
    flash one."""
    start = getattr(bar, "start_t", None)
    return start is None or time.time() - start >= getattr(bar, "delay", 0.0)


def progress_bar(total: int, desc: str, unit: str = "step", delay: float | None = None, enabled: bool = True,
                 **kw: Any) -> Any:
    """A tqdm bar over ``total`` steps named ``desc`` on stderr, shown after ``delay`` [s] (default
    :data:`DELAY_S`) and redrawn every :data:`TICK_S` by a daemon thread until closed; a :class:`NoBar`
    when not ``enabled`` or stderr is no terminal (tqdm not even imported: it costs start-up time)."""
    if not (enabled and on_terminal()):
        return NoBar(total)
    from tqdm import tqdm

    class _Ticking(tqdm):  # a step may take minutes (one Exudyn run): the bar still appears and ticks
        def __init__(self, *a: Any, **k: Any) -> None:
            super().__init__(*a, **k)
            self._stop = threading.Event()
            threading.Thread(target=self._tick, daemon=True, name="ked-progress").start()

        def _tick(self) -> None:
            while not self._stop.wait(TICK_S):
                if self.disable:
                    return
                if due(self):
                    self.refresh()

        def close(self) -> None:
            self._stop.set()
            super().close()

    return _Ticking(total=total, desc=desc, unit=unit, delay=DELAY_S if delay is None else delay, leave=False,
                    file=sys.stderr, dynamic_ncols=True, **kw)
