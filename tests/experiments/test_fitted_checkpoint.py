"""``fitted_checkpoint`` under a race: a worker that finishes a fit second keeps the first copy."""

import json

import lerobot_forcemap.cli.fit as cli_fit
from experiments.paper.jobs import Job
from experiments.paper.rollouts import fitted_checkpoint


def test_a_second_fit_keeps_the_first_workers_checkpoint(tmp_path, monkeypatch):
    job = Job("press", "defaults", "forcemap", 0, (6000,))
    real_fit = cli_fit.fit_policy
    raced = {}

    def fit_then_lose_the_race(dataset, out, **kw):
        result = real_fit(dataset, out, **kw)  # a real fit into this worker's temporary folder
        final = out.with_name(out.name.split(".tmp")[0])  # another worker renames its fit there first
        final.mkdir(parents=True)
        (final / "fit_info.json").write_text(json.dumps({"by": "first worker"}))
        raced["final"] = final
        return result

    monkeypatch.setattr(cli_fit, "fit_policy", fit_then_lose_the_race)
    ckpt, info = fitted_checkpoint(job, tmp_path)
    assert ckpt == raced["final"]
    assert info == {"by": "first worker"}  # the first copy stays: its worker may be loading it
    assert [p.name for p in ckpt.parent.iterdir()] == [ckpt.name]  # no temporary folder left behind
