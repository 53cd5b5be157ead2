"""One line, never a traceback: how every ``ked`` command ends when something goes wrong.

Bad input (click's usage errors, invalid configs, values outside the rules), files that are not
ours or not readable, OS failures (permissions, read-only or full disks) and interrupts each end
in one line on stderr naming the parameter or file, what is wrong and what is allowed, with a
non-zero exit status: 2 for bad input, 1 for a failure while working, 130 for an interrupt.
"""

from __future__ import annotations

import atexit
import errno
import gc
import os
import signal
import sys
import traceback
from collections.abc import Callable
from typing import Any

import click

from compare.stopping import STOP, raise_if_stopped, request_stop

EXIT_FAILURE = 1
EXIT_USAGE = 2
EXIT_INTERRUPTED = 130


class UserError(click.ClickException):
    """A problem the user can fix, with its one-line message (exit status 1)."""


class ProblemsError(click.UsageError):
    """Bad input with several problems (an invalid config or linkage file): one line each, each once, every line
    naming the file (exit status 2)."""

    def __init__(self, source: str, problems: list[str], hint: str = "") -> None:
        self.source, self.problems = source, list(dict.fromkeys(problems))
        self.hint = hint
        super().__init__("\n".join(self.lines()))

    def lines(self) -> list[str]:
        where = f"{self.source} ({self.hint})" if self.hint else self.source
        return [f"{where}: {p}" for p in self.problems]


LOW_MEMORY = ("not enough memory to load the numerical libraries (the memory limit, ulimit -v, is too low: they "
              "need about 500 MB of address space); raise the limit, e.g. ulimit -v unlimited")
MIN_ADDRESS_SPACE = 512 * 2**20
"""[bytes] Below this memory limit (ulimit -v) the harness is refused at start.  Measured with ``ked run`` of a
quasi-static campaign of 4 scenes (this project's 2-core machine): at 300 MB the imports failed now in Python
(ImportError, one line), now inside HDF5's initialization (its diagnostics before the line), at 350 MB OpenBLAS
aborted with its own message, at 400 MB a worker process could not start and the run waited for ever; at 500 MB
it ran."""


def check_memory_limit() -> None:
    """End in one line if the address-space limit is too low to even load numpy and its BLAS (which
    would otherwise abort with its own message, or fail the import)."""
    try:
        import resource
    except ImportError:  # pragma: no cover - not POSIX
        return
    soft, _ = resource.getrlimit(resource.RLIMIT_AS)
    if soft != resource.RLIM_INFINITY and soft < MIN_ADDRESS_SPACE:
        click.echo(f"ked: {LOW_MEMORY} (it is {soft / 2**20:.0f} MB)", err=True)
        sys.exit(EXIT_FAILURE)


def _internal(exc: BaseException) -> str:
    return (f"ked: internal error ({type(exc).__name__}: {first_line(str(exc))}); please report it with the "
            "command line")


def first_line(text: str) -> str:
    return str(text).strip().split("\n")[0]


def os_message(exc: OSError) -> str:
    """An OS error as one line: the file, what happened, what to do."""
    where = f"{exc.filename}: " if getattr(exc, "filename", None) else ""
    hints = {errno.ENOSPC: "the disk is full; free space and rerun",
             errno.EROFS: "the file system is read-only; choose a writable location",
             errno.EACCES: "permission denied; choose a location you may write to",
             errno.EPERM: "operation not permitted (an immutable file?); choose another location"}
    what = exc.strerror or first_line(str(exc))
    return f"{where}{what}" + (f" ({hints[exc.errno]})" if exc.errno in hints else "")


_STOP_SIGNALS = tuple(getattr(signal, n) for n in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, n))


def _terminate(signum: int, frame: object) -> None:
    """Ctrl-C, SIGTERM and SIGHUP all stop the command cleanly (stored results are kept).  The first
    one wins: the next ones are ignored, so they cannot interrupt the cleanup it started (stopping the
    workers, releasing the lock) and leave the command hanging or printing a traceback."""
    for s in _STOP_SIGNALS:
        signal.signal(s, signal.SIG_IGN)
    request_stop()  # kept even where Python drops the exception below (see compare.stopping)
    raise KeyboardInterrupt


def _from_h5py(tb: Any) -> bool:
    return any("h5py" in (frame.filename or "") for frame in traceback.extract_tb(tb))


def _quiet_unraisable(unraisable: Any) -> None:
    """HDF5 objects released after a failed write (a full disk) each report the failed flush again as
    an "Exception ignored" traceback; the failure itself was already reported in its one line.  A stop
    whose interrupt Python dropped the same way is not reported either: the command still stops."""
    if _from_h5py(unraisable.exc_traceback) or "h5py" in repr(unraisable.object):
        return
    if unraisable.exc_type is KeyboardInterrupt and STOP.is_set():
        return  # a stop raised inside a weakref callback or destructor: the loops still see STOP
    sys.__unraisablehook__(unraisable)


def _quiet_excepthook(kind: type[BaseException], value: BaseException, tb: Any) -> None:
    if _from_h5py(tb):  # the same, printed by h5py's deallocators through the except hook
        return
    sys.__excepthook__(kind, value, tb)


def _exit(code: int) -> None:
    """End a failed command with ``code``: release the HDF5 objects now (their errors are quiet), run
    Python's exit handlers, and skip the C library's: HDF5 would retry closing files it could not
    flush and crash there (a segmentation fault after the message on a full disk)."""
    try:
        gc.collect()
        atexit._run_exitfuncs()
    finally:
        for stream in (sys.stdout, sys.stderr):
            try:
                stream.flush()
            except (OSError, ValueError):
                pass
        os._exit(code)


STORING = ("run", "merge", "study", "plot")
"""The commands that write results or figures as they go (an interrupted one keeps them and resumes)."""


def interrupted(argv: list[str] | None = None) -> str:
    """The line an interrupted command ends with: a storing command (:data:`STORING`) keeps what it
    committed and resumes; any other has stored nothing."""
    args = sys.argv[1:] if argv is None else argv
    name = next((a for a in args if not a.startswith("-")), "")
    if name in STORING:
        return "ked: interrupted; results committed so far are kept (rerun to resume)"
    return "ked: interrupted; nothing was stored"


def run_guarded(command: Callable[..., object]) -> None:
    """Run a click command as a script; map every failure to one line and an exit status."""
    for s in _STOP_SIGNALS:
        if signal.getsignal(s) is not signal.SIG_IGN:  # e.g. nohup: a hang-up stays ignored
            signal.signal(s, _terminate)
    sys.unraisablehook = _quiet_unraisable
    sys.excepthook = _quiet_excepthook
    try:
        _run(command)
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else EXIT_FAILURE)
        if code == 0:
            raise
        _exit(code)


def _run(command: Callable[..., object]) -> None:
    try:
        command.main(standalone_mode=False, prog_name="ked")
        raise_if_stopped()  # the command ended although a stop was asked for: its interrupt was lost
    except click.exceptions.Exit as exc:
        sys.exit(exc.exit_code)
    except ProblemsError as exc:
        for line in exc.lines():
            click.echo(f"ked: {line}", err=True)
        sys.exit(EXIT_USAGE)
    except click.UsageError as exc:
        hint = f" (try '{exc.ctx.command_path} --help')" if exc.ctx is not None else ""
        click.echo(f"ked: {first_line(exc.format_message())}{hint}", err=True)
        sys.exit(EXIT_USAGE)
    except click.ClickException as exc:
        click.echo(f"ked: {exc.format_message()}", err=True)
        sys.exit(exc.exit_code)
    except (click.Abort, KeyboardInterrupt):
        click.echo(interrupted(), err=True)
        sys.exit(EXIT_INTERRUPTED)
    except BrokenPipeError:
        os._exit(0)  # the reader went away (ked ... | head): nothing left to say
    except OSError as exc:
        click.echo(f"ked: {os_message(exc)}", err=True)
        sys.exit(EXIT_FAILURE)
    except ImportError as exc:
        low = any(w in str(exc) for w in ("failed to map segment", "Cannot allocate memory"))
        click.echo(f"ked: {LOW_MEMORY}" if low else _internal(exc), err=True)
        sys.exit(EXIT_FAILURE)
    except MemoryError:
        click.echo("ked: out of memory; use a coarser step_deg or fewer lumps", err=True)
        sys.exit(EXIT_FAILURE)
    except Exception as exc:  # noqa: BLE001 - the last line of defence: still one line, with where to look
        click.echo(_internal(exc), err=True)
        sys.exit(EXIT_FAILURE)
