"""Reading the small JSON files a checkpoint or dataset carries, with errors that name the file.

data = read_json_object(folder / "config.json")   # dict, or ValueError "<path>: not valid JSON (...)"
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

__all__ = ["read_json_object"]


def read_json_object(path: str | Path) -> dict[str, Any]:
    """The JSON object stored at ``path``; ``ValueError`` naming the file if it is not valid JSON (or not
    UTF-8 text) or holds something other than an object. A missing file is left to the caller."""
    path = Path(path)
    try:
        data = json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as err:
        raise ValueError(f"{path}: not valid JSON ({err})") from err
    if not isinstance(data, dict):
        raise ValueError(f"{path}: expected a JSON object, got {type(data).__name__}")
    return data
