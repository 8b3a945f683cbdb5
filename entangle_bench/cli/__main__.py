"""`python -m entangle_bench.cli`: same as the `entangle-bench` script."""

import sys

from entangle_bench.cli import main

sys.exit(main())
