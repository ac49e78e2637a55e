"""Test-session settings: flown truth goes to a temporary truth store, never to the
user's cache folder (worker processes inherit the variable)."""

from __future__ import annotations

import os
import tempfile

os.environ["AEROTRUTH_CACHE"] = tempfile.mkdtemp(prefix="aerotruth-test-cache-")
