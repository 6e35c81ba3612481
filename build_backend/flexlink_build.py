"""flexlink's build backend: setuptools', with numba and what the build's warm-up runs import
requested for a wheel only (setup.py compiles the kernels into it), not for an editable
install or a source distribution, which compile nothing."""

from __future__ import annotations

import os
from typing import Any

from setuptools import build_meta as _setuptools
from setuptools.build_meta import *  # every hook not redefined here

KERNEL_REQUIRES = ["numpy>=1.26", "scipy>=1.11", "numba>=0.59", "threadpoolctl>=3.1"]


def get_requires_for_build_wheel(config_settings: dict[str, Any] | None = None) -> list[str]:
    """setuptools' requirements, and the kernels' unless FLEXLINK_BUILD_KERNELS is none."""
    requires = _setuptools.get_requires_for_build_wheel(config_settings)
    if os.environ.get("FLEXLINK_BUILD_KERNELS", "").strip() == "none":
        return requires
    return requires + KERNEL_REQUIRES
