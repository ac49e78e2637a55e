"""`python -m aerotruth`: the same command line as `aerotruth`."""

import sys

from aerotruth.cli import main

sys.exit(main())
