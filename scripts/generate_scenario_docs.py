"""Rewrite the generated key tables of docs/scenario.md from the scenario schema.

Usage: ``python scripts/generate_scenario_docs.py [--check] [PATH]``. The tables sit between
``<!-- generated: NAME -->`` and ``<!-- end generated -->``; everything else is hand-written
and kept. ``--check`` changes nothing and exits 1 when the file is out of date.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from flexlink.scenario.schema_docs import regenerate

DOCS = Path(__file__).resolve().parents[1] / "docs" / "scenario.md"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("path", nargs="?", type=Path, default=DOCS)
    parser.add_argument("--check", action="store_true",
                        help="exit 1 if the file differs from the schema, without writing it")
    args = parser.parse_args(argv)
    text = args.path.read_text(encoding="utf-8")
    new = regenerate(text)
    if new == text:
        return 0
    if args.check:
        print(f"{args.path} is out of date: run scripts/generate_scenario_docs.py",
              file=sys.stderr)
        return 1
    args.path.write_text(new, encoding="utf-8")
    print(f"rewrote {args.path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
