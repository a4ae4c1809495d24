"""Run every benchmark script in this folder (each has a main())."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

HERE = Path(__file__).parent


def main(names: list[str]) -> int:
    scripts = sorted(p for p in HERE.glob("bench_*.py"))
    if names:
        scripts = [p for p in scripts if p.stem in names or p.stem.removeprefix("bench_") in names]
    sys.path.insert(0, str(HERE))
    for path in scripts:
        print(f"=== {path.stem}", flush=True)
        spec = importlib.util.spec_from_file_location(path.stem, path)
        mod = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(mod)
        mod.main()
        print(flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
