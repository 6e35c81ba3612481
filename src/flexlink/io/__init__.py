"""Run folders: results (CSV, netCDF), the resolved scenario and figures."""

from .netcdf import write_netcdf_atomic
from .writers import OutputFolderError, check_output_dir, dump_toml, write_run

__all__ = ["OutputFolderError", "check_output_dir", "dump_toml", "write_netcdf_atomic", "write_run"]
