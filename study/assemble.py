"""Assemble the final netCDF of a run from its part files, region by region, atomically.

The coordinates and global attributes are written by xarray (``study.dataset.coords_of``,
``global_attrs``); the data variables are created once with netCDF4 and
filled one chunk at a time, so memory holds one chunk whatever the size of the cube. The
file's chunks are the compute chunks (outer axes by 1), which is what
``xarray.open_dataset(path, chunks={})`` hands to dask.
"""

from __future__ import annotations

import netCDF4
import numpy as np
import xarray as xr

from rimroll.study import io
from rimroll.study.dataset import coords_of
from rimroll.study.derived import derived_variables
from rimroll.study.parts import PartStore
from rimroll.study.plan import Plan


def assemble(plan: Plan, store: PartStore, path, attrs: dict) -> None:
    """Write ``path`` from the parts of every chunk of ``plan`` (all must be present).

    The temporary file lives in the parts folder, so one left by a kill is cleaned with it."""
    skeleton = xr.Dataset(coords=coords_of(plan.axes), attrs=attrs)
    encoding = {name: dict(io.COMPRESSION, _FillValue=None) for name in skeleton.coords}
    dims = tuple(a.name for a in plan.axes)
    outer_dims = dims[: len(plan.outer)]
    store.dir.mkdir(parents=True, exist_ok=True)
    with io.atomic_path(path, tmp_dir=store.dir) as tmp:  # a SIGKILL leaves it with the parts
        skeleton.to_netcdf(tmp, engine="netcdf4", format="NETCDF4", encoding=encoding)
        with netCDF4.Dataset(tmp, "a") as nc:
            variables = {}
            for v in plan.study.variables:
                vdims = outer_dims if v.outer else dims
                shape = tuple(nc.dimensions[d].size for d in vdims)
                chunks = shape if v.outer else plan.nc_chunks
                kind = np.dtype(v.dtype)
                fill = np.nan if kind.kind == "f" else False
                var = nc.createVariable(v.name, kind, vdims, fill_value=fill, chunksizes=chunks or None,
                                        zlib=bool(vdims), complevel=io.COMPRESSION["complevel"])
                var.set_auto_maskandscale(False)
                var.setncatts(v.attrs)
                variables[v.name] = (var, v.outer)
            for k in range(plan.n_chunks):
                arrays = store.load(k, plan.expected(k))
                if arrays is None:
                    raise RuntimeError(f"part {store.path(k)} vanished or was damaged during assembly; "
                                       "run again to recompute it")
                region = plan.region(k)
                for name, (var, outer) in variables.items():
                    var[region[: len(plan.outer)] if outer else region] = arrays[name]
        if plan.study.derive is not None:
            _add_derived(plan, tmp)


def _add_derived(plan: Plan, tmp) -> None:
    """Append the study's derived variables (``Study.derive`` on the whole grid) to ``tmp``."""
    with xr.open_dataset(tmp, engine="netcdf4") as ds:  # lazy: derive reads what it needs
        extra = derived_variables(plan.study, ds)
    dims_all = tuple(a.name for a in plan.axes)
    with netCDF4.Dataset(tmp, "a") as nc:
        for name, (dims, values, attrs) in extra.items():
            if dims == (name,) and name not in nc.dimensions:  # a new dimension and its coordinate
                nc.createDimension(name, values.shape[0])
            chunks = plan.nc_chunks if dims == dims_all else None
            var = nc.createVariable(name, values.dtype, dims, chunksizes=chunks, zlib=bool(dims),
                                    complevel=io.COMPRESSION["complevel"])
            var.set_auto_maskandscale(False)
            var.setncatts(attrs)
            var[...] = values
