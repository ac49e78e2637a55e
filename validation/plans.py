"""Plans for the wind-paper table runs: a prediction is only as blind as its plan.

A plan (validation/plans/<name>.yaml) fixes, before the runs that use it, the campaign and
its size, the seeds, the parameters changed (`set:`, as seed_runs.py --set), the paper's
scale each cell is judged at, the judged cells, the family-wise level and the number of
draws. `seed_runs.py --plan` refuses a plan that is not committed, or that has changes not
committed, and writes the plan's record (`plan.json`: name, path, the commit that last
changed it, its content hash) into every run folder; `paper_tables.py --plan` refuses runs
whose record is not the plan's as it stands. A plan changed after results exist is a new
plan: the runs made under the old content are refused under the new one, and a new name is
the way on. docs/wind-paper-tables.md lists every plan tried with its outcome.

    name: wind-tables-penair-1
    campaign: campaigns/penair_2010.yaml
    size: reduced
    seeds: 2010-2025
    set: []                  # PATH=VALUE, the parameters this plan varies
    paper_scale: {poor: 4, control: 3, days_before: 60, days_after: 62}
    judged: [poor.after_adjusted.total]
    level: 0.05
    draws: 4000
"""

from __future__ import annotations

import json
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import yaml

RECORD = "plan.json"
KEYS = {"name", "campaign", "size", "seeds", "set", "paper_scale", "judged", "level", "draws"}


def _git(repo: Path, *args: str) -> str:
    try:
        out = subprocess.run(["git", "-C", str(repo), *args], capture_output=True, text=True, check=True)
    except (OSError, subprocess.CalledProcessError) as exc:
        sys.exit(f"git {' '.join(args)}: {exc}")
    return out.stdout.strip()


@dataclass(frozen=True)
class Plan:
    name: str
    path: str  # as given
    campaign: str
    size: str
    seeds: str
    set: tuple[str, ...]
    scale: object  # aerotruth.analysis.wind.paper_draw.PaperScale
    judged: tuple[str, ...]
    level: float
    draws: int
    commit: str  # the commit that last changed the plan
    blob: str  # git's hash of its content

    @classmethod
    def load(cls, path: str) -> Plan:
        """The plan at `path`, refused unless committed and unchanged since (one line)."""
        from aerotruth.analysis.wind.paper_draw import PaperScale

        p = Path(path)
        try:
            doc = yaml.safe_load(p.read_text())
        except (OSError, yaml.YAMLError) as exc:
            sys.exit(f"{path}: cannot read the plan ({exc})")
        if not isinstance(doc, dict):
            sys.exit(f"{path}: expected a mapping with {sorted(KEYS)}")
        missing, extra = sorted(KEYS - set(doc)), sorted(set(doc) - KEYS)
        if missing or extra:
            sys.exit(f"{path}: plan keys: missing {missing}, unknown {extra} (expected {sorted(KEYS)})")
        sc = doc["paper_scale"]
        try:
            scale = PaperScale(**{k: int(sc[k]) for k in ("poor", "control", "days_before", "days_after")})
            level, draws = float(doc["level"]), int(doc["draws"])
        except (TypeError, KeyError, ValueError) as exc:
            sys.exit(f"{path}: paper_scale: expected poor, control, days_before, days_after >= 1; level, draws ({exc})")
        if not 0 < level < 1 or draws < 100:
            sys.exit(f"{path}: level: expected 0 < level < 1, draws >= 100; got {level}, {draws}")
        if not isinstance(doc["judged"], list) or not all(isinstance(c, str) for c in doc["judged"]):
            sys.exit(f"{path}: judged: expected a list of cells like poor.after_adjusted.total")
        if not isinstance(doc["set"], list):
            sys.exit(f"{path}: set: expected a list of PATH=VALUE strings (empty for none)")
        repo = p.resolve().parent
        rel = p.resolve().relative_to(Path(_git(repo, "rev-parse", "--show-toplevel")))
        if _git(repo, "status", "--porcelain", "--", str(p.resolve())):
            sys.exit(f"{path}: the plan has changes not committed: commit it before its runs (a plan is fixed first)")
        commit = _git(repo, "log", "-1", "--format=%H", "--", str(p.resolve()))
        if not commit:
            sys.exit(f"{path}: the plan is not committed: commit it before its runs (a plan is fixed first)")
        return cls(
            name=str(doc["name"]),
            path=str(rel),
            campaign=str(doc["campaign"]),
            size=str(doc["size"]),
            seeds=str(doc["seeds"]),
            set=tuple(str(x) for x in doc["set"]),
            scale=scale,
            judged=tuple(doc["judged"]),
            level=level,
            draws=draws,
            commit=commit,
            blob=_git(repo, "hash-object", str(p.resolve())),
        )

    def record(self) -> dict:
        return {"name": self.name, "path": self.path, "commit": self.commit, "blob": self.blob}


def write_record(plan: Plan, run_dir: Path) -> None:
    """Record the plan in a run folder; a folder made under another plan's content is refused."""
    run_dir.mkdir(parents=True, exist_ok=True)
    f = run_dir / RECORD
    if f.exists():
        old = json.loads(f.read_text())
        if old.get("blob") != plan.blob:
            sys.exit(
                f"{run_dir}: made under plan {old.get('name')!r} at {str(old.get('commit'))[:10]}, not this plan's "
                f"content: a plan changed after results exist is a new plan (give it a new name and folder)"
            )
        return
    f.write_text(json.dumps(plan.record(), indent=2) + "\n")


def check_runs(plan: Plan, run_dirs: list[str]) -> None:
    """Every run carries the plan's record as the plan stands, else one line and exit."""
    for d in run_dirs:
        f = Path(d) / RECORD
        if not f.exists():
            sys.exit(f"{d}: no {RECORD}: not a run of plan {plan.name!r} (seed_runs.py --plan writes it)")
        rec = json.loads(f.read_text())
        if rec.get("blob") != plan.blob:
            sys.exit(
                f"{d}: run under plan {rec.get('name')!r} at {str(rec.get('commit'))[:10]}; {plan.path} has changed "
                f"since (now {plan.commit[:10]}): a plan changed after results exist is a new plan"
            )
