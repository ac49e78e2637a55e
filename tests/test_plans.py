"""validation/plans.py: a plan is fixed in git before the runs that use it, and a plan changed
after results exist is a new plan."""

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "validation"))
import plans  # noqa: E402

PLAN = """name: wind-tables-test-1
campaign: campaigns/penair_2010.yaml
size: reduced
seeds: 2010-2012
set: []
paper_scale: {poor: 4, control: 3, days_before: 60, days_after: 62}
judged: [poor.after_adjusted.total]
level: 0.05
draws: 4000
"""


def _git(repo, *args):
    subprocess.run(["git", "-C", str(repo), *args], check=True, capture_output=True)


@pytest.fixture
def repo(tmp_path):
    _git(tmp_path, "init", "-q")
    _git(tmp_path, "config", "user.email", "t@example.org")
    _git(tmp_path, "config", "user.name", "t")
    (tmp_path / "plans").mkdir()
    return tmp_path


def test_a_plan_not_committed_or_changed_since_is_refused(repo):
    plan = repo / "plans" / "p.yaml"
    plan.write_text(PLAN)
    with pytest.raises(SystemExit, match="changes not committed"):
        plans.Plan.load(str(plan))  # untracked
    _git(repo, "add", ".")
    _git(repo, "commit", "-qm", "plan")
    p = plans.Plan.load(str(plan))
    assert (p.name, p.scale.poor, p.scale.days_after, p.judged, p.level) == (
        "wind-tables-test-1",
        4,
        62,
        ("poor.after_adjusted.total",),
        0.05,
    )
    assert p.path == "plans/p.yaml" and len(p.commit) == 40
    plan.write_text(PLAN.replace("level: 0.05", "level: 0.10"))
    with pytest.raises(SystemExit, match="changes not committed"):
        plans.Plan.load(str(plan))


def test_runs_of_an_old_plan_content_are_refused_under_the_new_one(repo, tmp_path):
    plan = repo / "plans" / "p.yaml"
    plan.write_text(PLAN)
    _git(repo, "add", ".")
    _git(repo, "commit", "-qm", "plan")
    first = plans.Plan.load(str(plan))
    run = tmp_path / "runs" / "base-2010"
    plans.write_record(first, run)
    plans.check_runs(first, [str(run)])  # the plan as it stands
    assert json.loads((run / "plan.json").read_text())["commit"] == first.commit
    # the judged cells changed after results exist, committed: a new plan
    plan.write_text(PLAN.replace("judged: [poor.after_adjusted.total]", "judged: [poor.improvement.total]"))
    _git(repo, "commit", "-qam", "plan changed")
    second = plans.Plan.load(str(plan))
    assert second.commit != first.commit
    with pytest.raises(SystemExit, match="a plan changed after results exist is a new plan"):
        plans.check_runs(second, [str(run)])
    with pytest.raises(SystemExit, match="a plan changed after results exist is a new plan"):
        plans.write_record(second, run)
    with pytest.raises(SystemExit, match="no plan.json"):
        plans.check_runs(second, [str(tmp_path / "runs" / "other")])


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (("level: 0.05", "level: 1.5"), "level: expected 0 < level < 1"),
        (("draws: 4000", "draws: 10"), "draws >= 100"),
        (("paper_scale: {poor: 4,", "paper_scale: {poor: 0,"), "paper_scale"),
        (("set: []", "set: x"), "set: expected a list"),
        (("name: wind-tables-test-1\n", ""), r"missing \['name'\]"),
    ],
)
def test_a_bad_plan_is_one_line_naming_the_field(repo, edit, message):
    plan = repo / "plans" / "p.yaml"
    plan.write_text(PLAN.replace(*edit))
    _git(repo, "add", ".")
    _git(repo, "commit", "-qm", "plan")
    with pytest.raises(SystemExit, match=message):
        plans.Plan.load(str(plan))


def test_seed_runs_under_a_plan_run_beside_its_record(repo):
    # the run folder holds the plan's record before its run: the run must go beside it
    from tiny_campaign import TINY_CAMPAIGN

    (repo / "tiny.yaml").write_text(TINY_CAMPAIGN)
    plan = repo / "plans" / "tiny.yaml"
    plan.write_text(
        PLAN.replace("campaigns/penair_2010.yaml", str(repo / "tiny.yaml"))
        .replace("size: reduced", "size: full")
        .replace("seeds: 2010-2012", "seeds: 3-4")
    )
    _git(repo, "add", ".")
    _git(repo, "commit", "-qm", "plan")
    out = repo / "runs"
    subprocess.run(
        [sys.executable, str(ROOT / "validation" / "seed_runs.py"), "--plan", str(plan), "--out", str(out)],
        capture_output=True,
        text=True,
        cwd=repo,
    )  # the tables step has no wind-paper tables to read in this campaign; the runs are the point
    for seed in (3, 4):
        run = out / f"base-{seed}"
        assert (run / "metrics.json").exists(), (run / f"../base-{seed}.log").read_text()
        assert json.loads((run / plans.RECORD).read_text())["name"] == "wind-tables-test-1"
