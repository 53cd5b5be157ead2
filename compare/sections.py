"""Marked sections of ``results/README.md``: each study owns the text between its own markers.

``<!-- BEGIN name -->`` ... ``<!-- END name -->``; everything outside one's own markers is left
byte-for-byte alone. :func:`replace_section` is pure; :func:`write_section` is the I/O edge.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

TITLE = "# ked-harness results\n"
_MARKER = re.compile(r"<!-- (BEGIN|END) (.*?) -->")


class SectionError(ValueError):
    """A README's section markers are malformed (the file is left as it is)."""


def check_markers(path: str | Path) -> None:
    """Raise :class:`SectionError` naming ``path`` unless it is a README the harness made (it holds section
    markers) whose every section is one BEGIN marker followed by its END marker, sections neither nested nor
    repeated (a missing file is fine: it will be created)."""
    path = Path(path)
    if not path.exists():
        return
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise SectionError(f"{path}: cannot be read as UTF-8 text ({exc})") from None
    open_name, seen = None, set()
    if not _MARKER.search(text):
        raise SectionError(f"{path}: not a results README the harness made (it has no section markers "
                           "'<!-- BEGIN name -->'); the harness writes only into files it created: give "
                           "--results-dir a directory of its own")
    for m in _MARKER.finditer(text):
        kind, name = m.groups()
        if kind == "BEGIN" and open_name is None and name not in seen:
            open_name = name
        elif kind == "END" and open_name == name:
            open_name = None
            seen.add(name)
        else:
            break
    else:
        if open_name is None:
            return
        m = None
    where = f"at {m.group(0)!r}" if m else f"<!-- END {open_name} --> is missing"
    raise SectionError(f"{path}: malformed section markers ({where}); each section must be one "
                       "'<!-- BEGIN name -->' line followed by its '<!-- END name -->' line: fix or remove them")


def markers(name: str) -> tuple[str, str]:
    """The begin and end marker lines of section ``name``."""
    return f"<!-- BEGIN {name} -->", f"<!-- END {name} -->"


def replace_section(text: str, name: str, body: str) -> str:
    """``text`` with the section ``name`` set to ``body`` (appended at the end if absent).

    Raises ValueError if the markers are present but malformed (one missing, or out of order)."""
    begin, end = markers(name)
    block = f"{begin}\n{body.strip()}\n{end}\n"
    i, j = text.find(begin), text.find(end)
    if i < 0 and j < 0:
        base = text if text.strip() else TITLE
        return base.rstrip("\n") + "\n\n" + block
    if i < 0 or j < 0 or j < i:
        raise ValueError(f"malformed markers for section {name!r}")
    tail = text[j + len(end):]
    return text[:i] + block.rstrip("\n") + tail


def write_section(path: str | Path, name: str, body: str) -> Path:
    """Set section ``name`` of the README at ``path`` (created with a title if missing); atomic."""
    path = Path(path)
    check_markers(path)
    text = path.read_text(encoding="utf-8") if path.exists() else TITLE
    new = replace_section(text, name, body)
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    tmp.write_text(new, encoding="utf-8")
    os.replace(tmp, path)
    return path


def section_of(text: str, name: str) -> str:
    """The content of section ``name`` ("" if absent)."""
    begin, end = markers(name)
    if begin not in text or end not in text:
        return ""
    return text[text.index(begin) + len(begin):text.index(end)].strip("\n")
