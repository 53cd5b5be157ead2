"""A stop requested by a signal, kept where a signal handler's exception cannot lose it.

A signal handler that raises (``KeyboardInterrupt`` on Ctrl-C, SIGTERM, SIGHUP) raises wherever the main
thread happens to be; inside a weakref callback or a destructor Python can only report the exception and
drops it, so the command would carry on to its end.  The handler therefore also sets :data:`STOP`, and the
loops that wait for work (:func:`compare.runner.run_tasks`) check it at least every :data:`POLL_S`.
"""
from __future__ import annotations

import threading

STOP = threading.Event()
"""Set once a stop was asked for (by the command line's signal handler); never cleared in that process."""

POLL_S = 0.25
"""How often (s) a waiting loop looks at :data:`STOP` while no task finishes."""


def request_stop() -> None:
    """Ask the running loops to stop (they raise ``KeyboardInterrupt`` at their next check)."""
    STOP.set()


def raise_if_stopped() -> None:
    """Raise ``KeyboardInterrupt`` if a stop was asked for."""
    if STOP.is_set():
        raise KeyboardInterrupt
