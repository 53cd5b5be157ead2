"""Reading a user's TOML file and checking its tables: every problem collected with its TOML path (unknown key,
wrong type, out-of-range value) and reported at once in a :class:`ConfigError`; a file that cannot be read, is
not UTF-8 text or not TOML is refused in one line naming it.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

try:  # Python >= 3.11
    import tomllib
except ModuleNotFoundError:  # pragma: no cover - Python 3.10
    import tomli as tomllib  # type: ignore[no-redef]



class ConfigError(ValueError):
    """Invalid campaign configuration; ``problems`` lists ``"toml.path: message"`` strings."""

    def __init__(self, problems: list[str], source: str = "campaign config"):
        self.problems = list(dict.fromkeys(problems))  # each problem once (a shared table is read per link)
        self.source = source
        lines = [f"{source}: {len(self.problems)} problem(s):"] + [f"  - {p}" for p in self.problems]
        super().__init__("\n".join(lines))


def read_text(p: Path) -> str:
    """The file's text; ConfigError naming the file if it cannot be read or is not UTF-8 text."""
    if p.exists() and not p.is_file() and not p.is_dir():  # a FIFO would block forever, a device never end
        raise ConfigError(["not a regular file (a FIFO, socket or device); give a TOML file"], source=str(p))
    try:
        return p.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise ConfigError(["not a text file (a TOML campaign config is UTF-8 text)"], source=str(p)) from None
    except IsADirectoryError:
        raise ConfigError(["is a directory, not a TOML file"], source=str(p)) from None
    except OSError as exc:
        raise ConfigError([f"cannot read file: {exc.strerror or exc}"], source=str(p)) from None


def read_toml(p: Path) -> dict[str, Any]:
    try:
        return tomllib.loads(read_text(p))
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError([f"TOML syntax error: {exc}"], source=str(p)) from None



def type_name(v: Any) -> str:
    return {bool: "boolean", int: "integer", float: "float", str: "string", list: "array",
            dict: "table"}.get(type(v), type(v).__name__)


class Checker:
    """Collects problems; every accessor returns ``None`` (or a default) on error."""

    def __init__(self) -> None:
        self.problems: list[str] = []
        self.bad: set[str] = set()

    def err(self, path: str, msg: str) -> None:
        self.problems.append(f"{path}: {msg}")
        self.bad.add(path)

    def keys(self, tab: dict[str, Any], path: str, allowed: tuple[str, ...]) -> None:
        for k in tab:
            if k not in allowed:
                p = f"{path}.{k}" if path else k
                self.err(p, f"unknown key (allowed: {', '.join(allowed)})")

    def table(self, tab: dict[str, Any], key: str, path: str | None = None) -> dict[str, Any]:
        v = tab.get(key, {})
        if not isinstance(v, dict):
            self.err(path or key, f"must be a table, got {type_name(v)}")
            return {}
        return v

    def _get(self, tab: dict[str, Any], path: str, required: bool) -> tuple[bool, Any]:
        key = path.rsplit(".", 1)[-1]
        if key not in tab:
            if required:
                self.err(path, "required")
            return False, None
        return True, tab[key]

    def check(self, tab, path, fn, *, default=None, required=False):
        """A value checked by ``fn(value, path)`` (which raises ValueError with the message)."""
        present, v = self._get(tab, path, required)
        if not present:
            return default
        try:
            return fn(v, path)
        except ValueError as exc:
            self.problems.append(str(exc))
            self.bad.add(path)
            return None

    def rule(self, tab, path, rule, *, default=None, required=False):
        """A value checked by a :class:`ked_quasi.rules.Rule`."""
        return self.check(tab, path, rule.check, default=default, required=required)

    def rules(self, tab, path, rule, *, default=()):
        """An array of values, each checked by a :class:`ked_quasi.rules.Rule`; duplicates refused."""
        v, dflt = self._array(tab, path, default)
        if v is None:
            return tuple(dflt)
        out = []
        for i, x in enumerate(v):
            try:
                y = rule.check(x, f"{path}[{i}]")
            except ValueError as exc:
                self.problems.append(str(exc))
                self.bad.add(f"{path}[{i}]")
                continue
            out.append(y)
        if len(set(out)) != len(out):
            self.err(path, f"duplicate values in {v!r}")
        return tuple(out)

    def number(self, tab, path, *, default=None, lo=None, hi=None, lo_open=False, required=False):
        present, v = self._get(tab, path, required)
        if not present:
            return default
        return self._check_number(v, path, lo, hi, lo_open)

    def _check_number(self, v, path, lo, hi, lo_open):
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            self.err(path, f"must be a number, got {type_name(v)} {v!r}")
            return None
        v = float(v)
        if not math.isfinite(v):
            self.err(path, f"must be finite, got {v!r}")
            return None
        if lo is not None and (v < lo or (lo_open and v == lo)):
            self.err(path, f"must be {'>' if lo_open else '>='} {lo:g}, got {v:g}")
            return None
        if hi is not None and v > hi:
            self.err(path, f"must be <= {hi:g}, got {v:g}")
            return None
        return v

    def integer(self, tab, path, *, default=None, lo=None, hi=None, required=False):
        present, v = self._get(tab, path, required)
        if not present:
            return default
        if isinstance(v, bool) or not isinstance(v, int):
            self.err(path, f"must be an integer, got {type_name(v)} {v!r}")
            return None
        if (lo is not None and v < lo) or (hi is not None and v > hi):
            self.err(path, f"must be in [{lo}, {hi}], got {v}")
            return None
        return v

    def boolean(self, tab, path, *, default=None):
        present, v = self._get(tab, path, False)
        if not present:
            return default
        if not isinstance(v, bool):
            self.err(path, f"must be a boolean, got {type_name(v)} {v!r}")
            return None
        return v

    def string(self, tab, path, *, default=None, choices=None, required=False):
        present, v = self._get(tab, path, required)
        if not present:
            return default
        if not isinstance(v, str):
            self.err(path, f"must be a string, got {type_name(v)} {v!r}")
            return None
        if choices is not None and v not in choices:
            self.err(path, f"must be one of {', '.join(repr(x) for x in choices)}, got {v!r}")
            return None
        return v

    def like(self, tab, path, default):
        """Type-check against the type of a default value (unknown-range settings)."""
        if isinstance(default, bool):
            return self.boolean(tab, path)
        if isinstance(default, int):
            return self.integer(tab, path)
        if isinstance(default, float):
            return self.number(tab, path)
        if isinstance(default, str):
            return self.string(tab, path)
        present, v = self._get(tab, path, False)
        if isinstance(v, (dict, list)):
            self.err(path, f"must be a scalar, got {type_name(v)}")
            return None
        return v

    def _array(self, tab, path, default):
        present, v = self._get(tab, path, False)
        if not present:
            return None, default
        if not isinstance(v, list):
            self.err(path, f"must be an array, got {type_name(v)} {v!r}")
            return None, ()
        if not v:
            self.err(path, "must not be empty")
            return None, ()
        return v, None

    def choices(self, tab, path, allowed, *, default=()):
        v, dflt = self._array(tab, path, default)
        if v is None:
            return tuple(dflt)
        out = []
        for i, x in enumerate(v):
            if not isinstance(x, str) or x not in allowed:
                self.err(f"{path}[{i}]", f"must be one of {', '.join(repr(a) for a in allowed)}, got {x!r}")
            else:
                out.append(x)
        if len(set(out)) != len(out):
            self.err(path, f"duplicate values in {v!r}")
        return tuple(out)
