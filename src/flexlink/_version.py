"""The installed package's version (one place for the CLI, result files and resolved scenarios)."""

from functools import cache
from importlib.metadata import PackageNotFoundError, version


@cache  # reading the package metadata is slow; a sweep resolves thousands of scenarios
def package_version() -> str:
    try:
        return version("flexlink")
    except PackageNotFoundError:  # running from a source tree that is not installed
        return "0+unknown"
