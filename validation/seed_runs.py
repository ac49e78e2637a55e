"""A campaign over several campaign seeds, optionally with parameters changed: the seed grid
behind each calibration and prediction in the wind-paper campaigns' YAML comments.

For every seed: copies the campaign with `seed:` set and each `--set` applied, runs it
(`aerotruth run COPY --size SIZE --out OUT/<tag>-<seed>`, one after the other, each using
all cores), then prints the paper-table summary of the finished runs (validation/
paper_tables.py: mean, seed-to-seed sd, standard error, judged cells, calibration chi2).
A seed whose run directory already holds metrics.json is not run again, so a grid can be
stopped and resumed. Sensor-only variants re-use the flown truth from the truth store
(seconds a seed); the first run of a seed flies it (minutes).

    python validation/seed_runs.py campaigns/penair_2010.yaml --seeds 2010-2014 --out runs/seeds
    python validation/seed_runs.py campaigns/penair_2010.yaml --seeds 2010-2014 --out runs/seeds \\
        --tag hi620 --set studies.heading_correction.sensors.fleets.penair.heading.poor_hard_iron_sigma_nT=620 \\
        --baseline-tag base

`--set PATH=VALUE`: PATH dotted through the YAML's mappings (a list item by its index, or
by the value of its `name:`), VALUE parsed as YAML (`620`, `2003-01-01`, `[a, b]`). The
path must already exist, so a misspelt key is an error, not a silently added one; and a
path that the chosen size's block sets itself is an error too (the size, merged over the
campaign when it runs, would undo the change).
`--baseline-tag T`: also print the paired differences against the runs OUT/T-<seed>
(the same seeds; see paper_tables.py --baseline).
`--plan PLAN`: the campaign, size, seeds and `--set` changes from a committed plan
(validation/plans.py; refused when not committed or changed since), its record written into
every run folder before the run, and the summary judged by it (paper_tables.py --plan).
`--truth-max-gb N`: the truth store's size cap for these runs (`truth_store.max_gb`,
default 20). Each run evicts the least recently used flights beyond the cap when it ends;
a grid of many seeds outgrows 20 GB (a reduced PenAir seed is ~1.2 GB of truth), and a
seed evicted mid-grid is flown again by its next variant (minutes instead of seconds).
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from pathlib import Path

import yaml

HERE = Path(__file__).resolve().parent


def parse_seeds(text: str) -> list[int]:
    """'2010-2014' or '2010,2012,2015' (or a mix) -> the seeds."""
    seeds: list[int] = []
    for part in text.split(","):
        lo, _, hi = part.strip().partition("-")
        try:
            seeds += list(range(int(lo), int(hi) + 1)) if hi else [int(lo)]
        except ValueError:
            sys.exit(f"--seeds: expected integers or ranges like 2010-2014, got {part!r}")
    return seeds


def apply_set(doc: dict, assignment: str) -> None:
    """Apply one `PATH=VALUE` to the loaded campaign, in place."""
    path, sep, raw = assignment.partition("=")
    if not sep or not path:
        sys.exit(f"--set: expected PATH=VALUE, got {assignment!r}")
    keys = path.split(".")
    node = doc
    for i, key in enumerate(keys):
        where = ".".join(keys[: i + 1])
        last = i == len(keys) - 1
        if isinstance(node, list):
            match = [j for j, item in enumerate(node) if isinstance(item, dict) and item.get("name") == key]
            if key.isdigit() and int(key) < len(node):
                idx = int(key)
            elif len(match) == 1:
                idx = match[0]
            else:
                sys.exit(f"--set {path}: {where!r} is neither an index nor a `name:` of the list there")
            if last:
                node[idx] = yaml.safe_load(raw)
            node = node[idx]
        elif isinstance(node, dict):
            if key not in node:
                sys.exit(f"--set {path}: the campaign has no {where!r} (keys there: {', '.join(map(str, node))})")
            if last:
                node[key] = yaml.safe_load(raw)
            node = node[key]
        else:
            sys.exit(f"--set {path}: {'.'.join(keys[:i])!r} is a value, not a mapping or list")


def check_not_shadowed(doc: dict, assignment: str, size: str) -> None:
    """Exit if the size block `sizes.<size>` itself sets what `PATH=VALUE` changes: the size
    is merged over the campaign when it runs (mappings key by key, lists and values
    replaced), so the change would be silently undone. Paths under `sizes.` are left alone."""
    path = assignment.partition("=")[0]
    keys = path.split(".")
    if size == "full" or keys[0] == "sizes":
        return
    node = (doc.get("sizes") or {}).get(size)
    for i, key in enumerate(keys):
        if not isinstance(node, dict) or key not in node:
            return
        node = node[key]
        if i == len(keys) - 1 or not isinstance(node, dict):
            sys.exit(
                f"--set {path}: the size {size!r} sets {'.'.join(['sizes', size, *keys[: i + 1]])} itself, which "
                f"would undo this change when the size is merged in; set sizes.{size}.{path} instead (or as well)"
            )


def with_truth_cap(doc: dict, max_gb: float | None) -> None:
    """Set the campaign's truth-store cap (GB) in place; None leaves it as it is."""
    if max_gb is None:
        return
    if max_gb <= 0:
        sys.exit(f"--truth-max-gb: expected a positive size in GB, got {max_gb:g}")
    store = doc.get("truth_store") or {}
    if not isinstance(store, dict):
        sys.exit("truth_store: expected a mapping in the campaign")
    doc["truth_store"] = {**store, "max_gb": max_gb}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("campaign", nargs="?", help="campaign YAML (from the plan with --plan)")
    ap.add_argument("--seeds", help="e.g. 2010-2014 or 2010,2015-2019 (from the plan with --plan)")
    ap.add_argument("--plan", help="a committed plan (validation/plans/*.yaml): campaign, size, seeds and changes")
    ap.add_argument("--out", required=True, help="directory of the runs (OUT/<tag>-<seed>)")
    ap.add_argument("--tag", default="base", help="name of this variant (default base)")
    ap.add_argument("--set", action="append", default=[], metavar="PATH=VALUE", help="change a campaign parameter")
    ap.add_argument("--size", default="reduced", help="the campaign's size (default reduced; 'full' for none)")
    ap.add_argument("--baseline-tag", help="print paired differences against OUT/<this tag>-<seed>")
    ap.add_argument(
        "--truth-max-gb", type=float, help="the truth store's size cap for these runs (default: the campaign's)"
    )
    a = ap.parse_args()
    plan = None
    if a.plan:
        sys.path.insert(0, str(HERE))
        from plans import Plan

        plan = Plan.load(a.plan)
        if a.campaign or a.seeds or a.set or a.size != "reduced":
            sys.exit("--plan: the campaign, --seeds, --set and --size come from the plan; give none of them")
        a.campaign, a.seeds, a.set, a.size = plan.campaign, plan.seeds, list(plan.set), plan.size
    elif not a.campaign or not a.seeds:
        sys.exit("expected a campaign YAML and --seeds (or --plan)")

    src = Path(a.campaign)
    try:
        doc = yaml.safe_load(src.read_text())
    except (OSError, yaml.YAMLError) as exc:
        sys.exit(f"{src}: cannot read the campaign ({exc})")
    if not isinstance(doc, dict) or "seed" not in doc:
        sys.exit(f"{src}: expected a campaign mapping with a `seed:`")
    for s in a.set:
        check_not_shadowed(doc, s, a.size)
        apply_set(doc, s)
    with_truth_cap(doc, a.truth_max_gb)
    seeds = parse_seeds(a.seeds)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    runs = []
    for seed in seeds:
        run = out / f"{a.tag}-{seed}"
        runs.append(run)
        if plan is not None:
            from plans import write_record

            write_record(plan, run)
        if (run / "metrics.json").exists():
            print(f"{run}: done before, kept", flush=True)
            continue
        doc["seed"] = seed
        copy = out / f"{a.tag}-{seed}.yaml"
        copy.write_text(
            f"# {src} with seed {seed}" + "".join(f"; {s}" for s in a.set) + "\n" + yaml.safe_dump(doc, sort_keys=False)
        )
        cmd = ["aerotruth", "run", str(copy), "--out", str(run), "--quiet", "--no-report"]
        if plan is not None:
            cmd.append("--force")  # the folder holds the plan's record, which the run writes beside
        if a.size != "full":
            cmd[3:3] = ["--size", a.size]
        t0 = time.perf_counter()
        with open(out / f"{a.tag}-{seed}.log", "w") as log:
            rc = subprocess.call(cmd, stdout=log, stderr=subprocess.STDOUT)
        if rc:
            sys.exit(f"{run}: `{' '.join(cmd)}` failed (exit {rc}); see {out / f'{a.tag}-{seed}.log'}")
        print(f"run_seconds.{a.tag}.{seed}: {time.perf_counter() - t0:.0f}", flush=True)
    tables = [sys.executable, str(HERE / "paper_tables.py"), *map(str, runs)]
    if plan is not None:
        tables += ["--plan", a.plan]
    if a.baseline_tag:
        tables += ["--baseline", *(str(out / f"{a.baseline_tag}-{seed}") for seed in seeds)]
    sys.exit(subprocess.call(tables))


if __name__ == "__main__":
    main()
