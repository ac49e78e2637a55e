"""Test-session settings: flown truth goes to a temporary truth store, never to the
user's cache folder (worker processes inherit the variable), removed when the test process
ends.

The suite runs on two pytest-xdist processes (pyproject's addopts: `-n 2 --dist loadfile`,
each file on one process so a file's flights are flown once). Its longest files start
first: the quick campaign alone is ~3 min of JSBSim, and started last it would run with
the other process idle. `pytest -n 0` runs the suite in one process."""

from __future__ import annotations

import atexit
import os
import shutil
import tempfile

_CACHE = tempfile.mkdtemp(prefix="aerotruth-test-cache-")
os.environ["AEROTRUTH_CACHE"] = _CACHE
atexit.register(shutil.rmtree, _CACHE, ignore_errors=True)  # each test process removes its own at exit

if os.environ.get("PYTEST_XDIST_WORKER"):
    # two test processes share the cores: one BLAS/OpenMP thread each, as campaign
    # workers have (set before numpy is first imported by a test module)
    for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(var, "1")

# the longest files, in the order they should start (their summed test times on two
# processes, 27 Nov 2026: 228, 112, 80, 70, 54, 52, 38, 29, 26, 24, 23, 23, 23 s; the two
# halves of the fuzz corpus, added later: 41 and 37 s on one process)
LONGEST_FIRST = (
    "test_quick_regression.py",
    "test_diagnose_wind.py",
    "test_diagnose.py",
    "test_flight.py",
    "test_fuzz_campaigns.py",
    "test_fuzz.py",
    "test_toy_study.py",
    "test_honest_caching.py",
    "test_inspection_study.py",
    "test_campaign_truth.py",
    "test_diagnose_fits.py",
    "test_heading_correction.py",
    "test_campaign_run.py",
    "test_wind_reports_study.py",
    "test_dask_cluster.py",
)


def pytest_collection_modifyitems(session, config, items):
    rank = {name: i for i, name in enumerate(LONGEST_FIRST)}
    items.sort(key=lambda item: rank.get(item.path.name, len(rank)))  # stable: the rest keep their order
