"""Regenerate the current-figures table of benchmarks/README.md from benchmarks/current.json
(the same as ``terrapath bench --table``).

Run: ``.venv/bin/python -m benchmarks.table``
"""

from __future__ import annotations

from pathlib import Path

from terrapath import figures

HERE = Path(__file__).resolve().parent


def main() -> int:
    print(figures.remake_table(HERE / "current.json", HERE / "README.md"))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
