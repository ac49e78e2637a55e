"""`python -m aerotruth`: the same command line as `aerotruth`."""

import sys

from aerotruth.app.cli import main

sys.exit(main())
