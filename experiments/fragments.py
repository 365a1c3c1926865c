"""Findings prose of the generated reports: Markdown fragments filled in from the numbers.

A template file (``<name>.md`` in a ``templates/`` folder next to the code that writes the report)
holds named fragments, each introduced by a line ``<!-- fragment-name -->`` and running to the next
such line (trailing blank lines dropped, blank lines inside kept). The code picks the fragments a
result calls for (a conditional sentence is a fragment of its own) and fills each with
``str.format_map``: named fields with format specs (``{dmax:+.1f}``), literal braces doubled.

    text = Fragments(Path(__file__).parent / "templates" / "analysis.md")
    line = text("press_default", dmax=-56.4, dmean=-57.9)
"""

from __future__ import annotations

import functools
import re
from pathlib import Path
from typing import Any

__all__ = ["Fragments", "TemplateError"]

_MARKER = re.compile(r"^<!-- ([a-z0-9_]+) -->$")


@functools.cache
def _read(path: Path) -> dict[str, str]:
    fragments: dict[str, list[str]] = {}
    current: list[str] | None = None
    for line in path.read_text().splitlines():
        m = _MARKER.match(line)
        if m:
            if m.group(1) in fragments:
                raise TemplateError(f"{path}: fragment {m.group(1)!r} is defined twice")
            current = fragments[m.group(1)] = []
        elif current is not None:
            current.append(line)
    return {name: "\n".join(lines).rstrip("\n") for name, lines in fragments.items()}


class TemplateError(Exception):
    """A fragment the code asks for is not in the template, or a field it names was not given (a bug
    of the template or the code, never of the results: not caught where partial results are)."""


class Fragments:
    """The fragments of one template file; ``fragments(name, **values)`` is one filled in."""

    def __init__(self, path: Path):
        self.path = Path(path)

    def __call__(self, name: str, /, **values: Any) -> str:
        texts = _read(self.path)
        if name not in texts:
            raise TemplateError(f"{self.path}: no fragment {name!r}")
        try:
            return texts[name].format_map(values)
        except (KeyError, IndexError, ValueError) as err:
            raise TemplateError(f"{self.path}: fragment {name!r}: {err!r}") from err
