"""A campaign run killed (SIGKILL to the main process) while it flies, resumed, killed again
and resumed to the end, against the same campaign run uninterrupted: each into an empty
truth store of its own. Prints `label: value` lines:

  uninterrupted_seconds, interrupted_seconds: wall time of each (the interrupted run's
    three parts together);
  killed_at_<k>: seconds into the part when kill k came, and legs stored by then;
  metrics_identical: 1 when the two metrics.json files are byte-identical;
  legs_flown_uninterrupted, legs_flown_interrupted: "flown" lines of each store's flown.log;
  legs_flown_twice: keys with more than one "flown" line in the interrupted store's log (a
    leg killed in flight was never stored and is flown again once; a stored leg is read).

    python validation/kill_resume.py campaigns/penair_2010.yaml --size reduced [--at 0.3,0.6]

`--at`: the kills' moments as fractions of the uninterrupted run's wall time, measured from
the start of each part (default 0.3,0.3: each part is killed about a third of the way in).
"""

from __future__ import annotations

import argparse
import collections
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def start(campaign: str, size: str, out: Path, cache: Path) -> subprocess.Popen:
    cmd = ["aerotruth", "run", campaign, "--out", str(out), "--quiet", "--no-report"]
    if size != "full":
        cmd += ["--size", size]
    env = dict(os.environ, AEROTRUTH_CACHE=str(cache))
    return subprocess.Popen(cmd, env=env, start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)


def flown(cache: Path) -> collections.Counter:
    log = cache / "truth" / "flown.log"
    if not log.exists():
        return collections.Counter()
    lines = [json.loads(x) for x in log.read_text().splitlines() if x.strip()]
    return collections.Counter(x["key"] for x in lines if x.get("what") == "flown")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("campaign")
    ap.add_argument("--size", default="reduced")
    ap.add_argument("--at", default="0.3,0.3", help="kill moments, fractions of the uninterrupted wall time")
    a = ap.parse_args()
    try:
        moments = [float(x) for x in a.at.split(",")]
    except ValueError:
        sys.exit(f"--at: expected fractions like 0.3,0.6, got {a.at!r}")
    if not all(0 < m < 1 for m in moments):
        sys.exit(f"--at: expected fractions between 0 and 1, got {a.at!r}")
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        t0 = time.monotonic()
        ref = start(a.campaign, a.size, root / "ref", root / "cache-ref")
        if ref.wait() != 0:
            sys.exit(f"the uninterrupted run failed: {ref.stderr.read().decode()[-400:]}")
        wall = time.monotonic() - t0
        print(f"uninterrupted_seconds: {wall:.0f}", flush=True)
        out, cache = root / "killed", root / "cache-killed"
        t1 = time.monotonic()
        for k, m in enumerate(moments, 1):
            proc = start(a.campaign, a.size, out, cache)
            try:
                proc.wait(timeout=m * wall)
                sys.exit(f"kill {k}: the run ended before {m * wall:.0f} s; choose an earlier moment")
            except subprocess.TimeoutExpired:
                pass
            os.kill(proc.pid, signal.SIGKILL)  # the main process only, as `kill -9 PID` does
            proc.wait()
            print(f"killed_at_{k}: {m * wall:.0f} s, {sum(flown(cache).values())} legs stored", flush=True)
        last = start(a.campaign, a.size, out, cache)
        if last.wait() != 0:
            sys.exit(f"the resumed run failed: {last.stderr.read().decode()[-400:]}")
        print(f"interrupted_seconds: {time.monotonic() - t1:.0f}")
        same = (root / "ref" / "metrics.json").read_bytes() == (out / "metrics.json").read_bytes()
        print(f"metrics_identical: {int(same)}")
        ref_legs, got = flown(root / "cache-ref"), flown(cache)
        print(f"legs_flown_uninterrupted: {sum(ref_legs.values())}")
        print(f"legs_flown_interrupted: {sum(got.values())}")
        print(f"legs_flown_twice: {sum(1 for n in got.values() if n > 1)}")


if __name__ == "__main__":
    main()
