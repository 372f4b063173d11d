"""`python -m shoulder_bench.cli` = `shoulder-bench`."""
import sys

from shoulder_bench.cli import run

sys.exit(run())
