"""Run every benchmark in this folder, one after the other, and print their tables.

Each ``bench_*.py`` measures mitsar against a baseline timed in the same run (ratios, not
absolute seconds), so results compare across machines. Usage: ``python benchmarks/run_all.py``.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path


def main() -> int:
    failures = 0
    for script in sorted(Path(__file__).parent.glob("bench_*.py")):
        print(f"== {script.name}", flush=True)
        result = subprocess.run([sys.executable, str(script)], check=False)
        failures += result.returncode != 0
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
