"""The README's `flexlink compare` and `flexlink fit` commands run as written on the shipped
measured-data example (examples/lab_run3.csv, scripts/lab_record.py)."""

from __future__ import annotations

import shlex
from pathlib import Path

import pytest

from flexlink.cli import main

ROOT = Path(__file__).resolve().parents[2]


def readme_command(name: str) -> list[str]:
    """The README's `flexlink <name>` command (continuation lines joined, comments dropped)."""
    lines = (ROOT / "README.md").read_text(encoding="utf-8").splitlines()
    for i, line in enumerate(lines):
        if line.startswith(f"flexlink {name} "):
            text = ""
            while True:
                part = lines[i].split(" #")[0].rstrip()
                text += part.removesuffix("\\") + " "
                if not part.endswith("\\"):
                    return shlex.split(text)
                i += 1
    raise AssertionError(f"no `flexlink {name}` command in README.md")


@pytest.mark.parametrize("name", ["compare", pytest.param("fit", marks=pytest.mark.slow)])
def test_the_readme_measurement_commands_run_on_the_example(name: str, tmp_path: Path,
                                                            monkeypatch) -> None:
    args = readme_command(name)[1:]
    out = args.index("-o") + 1
    assert (ROOT / args[1]).is_file() and (ROOT / args[2]).is_file()
    args[out] = str(tmp_path / args[out])
    monkeypatch.chdir(ROOT)
    assert main([*args, "-q", "--no-figures"]) == 0
    assert (tmp_path / readme_command(name)[out + 1] / "report.html").is_file()
