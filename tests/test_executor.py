"""The executor: the same results in this process, on a process pool and on a real local Ray instance.

A dataset-wide fit (``forcemap fit --all-episodes``'s code path) and a small evaluation run on the
default pool and on Ray (``ray.init(num_cpus=2)``): the skill libraries (index and every checkpoint's
tensors, byte for byte) and the evaluation records are identical. Skipped without the ``ray`` extra.
"""

from __future__ import annotations

import json
import math
import sys

import pytest

from lerobot_forcemap.executor import MissingRayError, make_executor
from tests.conftest import REPO_ROOT

DATASET = REPO_ROOT / "datasets" / "press"


def test_map_keeps_the_order_of_the_jobs_and_checks_workers():
    jobs = [9.0, 1.0, 4.0, 16.0, 0.0]
    with make_executor(1) as serial:
        assert serial.kind == "serial" and serial.map(math.sqrt, jobs, progress=False) == [3, 1, 2, 4, 0]
    with pytest.raises(ValueError, match="workers: must be an integer >= 1, got 0"):
        make_executor(0)


def test_ray_without_the_extra_says_how_to_install_it(monkeypatch):
    monkeypatch.setitem(sys.modules, "ray", None)  # import ray raises ImportError
    with pytest.raises(MissingRayError, match=r'pip install "lerobot_forcemap\[ray\]"'):
        make_executor(2, ray=True)


def _library(root):
    """The index and every checkpoint's files (bytes) of a skill library, timings left out."""
    index = json.loads((root / "index.json").read_text())
    files = {
        str(p.relative_to(root)): p.read_bytes()
        for p in sorted(root.rglob("*"))
        if p.is_file() and p.name not in ("index.json", "fit_report.json")
    }
    reports = {
        str(p.relative_to(root)): {k: v for k, v in json.loads(p.read_text()).items() if k != "fit_seconds"}
        for p in sorted(root.rglob("fit_report.json"))
    }
    return index, files, reports


def _without_wall_time(records):
    """The records less ``wall_s`` (the episode's wall-clock time: the one figure that may differ)."""
    return [{k: v for k, v in r.items() if k != "wall_s"} for r in records]


def test_dataset_fit_and_evaluation_same_on_pool_and_ray(tmp_path):
    pytest.importorskip("ray")
    from lerobot_forcemap.cli.fit_dataset import fit_dataset
    from lerobot_forcemap.evaluation.evaluate import evaluate_policy

    results = {}
    for name, kwargs in (("pool", {}), ("ray", {"ray": True})):
        with make_executor(2, **kwargs) as ex:
            assert ex.kind == name
            index = fit_dataset(DATASET, tmp_path / name, ex, progress=False)
            checkpoint = tmp_path / name / index["episodes"][0]["folder"]
            records = _without_wall_time(
                evaluate_policy(checkpoint, "press", 2, 1000, progress=False, executor=ex)
            )
        results[name] = (_library(tmp_path / name), records)
    (pool_lib, pool_records), (ray_lib, ray_records) = results["pool"], results["ray"]
    index = pool_lib[0]
    assert index["counts"] == {"ok": index["total_episodes"], "refused": 0, "failed": 0}
    assert [r["episode"] for r in index["episodes"]] == list(range(index["total_episodes"]))
    assert all(r["events"] and r["segments"] for r in index["episodes"])
    assert pool_lib == ray_lib
    assert [r["episode"] for r in pool_records] == [0, 1] and pool_records == ray_records
