"""read_json_object: the file named in every error."""

from __future__ import annotations

import pytest

from lerobot_forcemap.jsonfile import read_json_object


def test_read_json_object(tmp_path):
    path = tmp_path / "a.json"
    path.write_text('{"x": [1, 2]}')
    assert read_json_object(path) == {"x": [1, 2]}
    path.write_text("{oops")
    with pytest.raises(ValueError, match=r"a\.json: not valid JSON \(Expecting property name"):
        read_json_object(path)
    path.write_text("[1, 2]")
    with pytest.raises(ValueError, match=r"a\.json: expected a JSON object, got list"):
        read_json_object(path)
    path.write_bytes(b"\xff\xfe")
    with pytest.raises(ValueError, match=r"a\.json: not valid JSON"):
        read_json_object(path)
