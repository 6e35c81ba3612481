"""flexlink's build backend: setuptools', with numba and what the build's warm-up runs import
requested for a wheel and an editable install (setup.py compiles the kernels into the
package they install), not for a source distribution, which compiles nothing."""

from __future__ import annotations

import os
from typing import Any

from setuptools import build_meta as _setuptools
from setuptools.build_meta import *  # every hook not redefined here

KERNEL_REQUIRES = ["numpy>=1.26", "scipy>=1.11", "numba>=0.59", "threadpoolctl>=3.1"]


def _with_kernels(requires: list[str]) -> list[str]:
    """`requires` and the kernels' requirements unless FLEXLINK_BUILD_KERNELS is none."""
    if os.environ.get("FLEXLINK_BUILD_KERNELS", "").strip() == "none":
        return requires
    return requires + KERNEL_REQUIRES


def get_requires_for_build_wheel(config_settings: dict[str, Any] | None = None) -> list[str]:
    """setuptools' requirements for a wheel, and the kernels'."""
    return _with_kernels(_setuptools.get_requires_for_build_wheel(config_settings))


def get_requires_for_build_editable(config_settings: dict[str, Any] | None = None,
                                    ) -> list[str]:
    """setuptools' requirements for an editable install, and the kernels'."""
    return _with_kernels(_setuptools.get_requires_for_build_editable(config_settings))
