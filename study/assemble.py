"""Assemble the final netCDF of a run from its part files, atomically, one storage block at a time.

The coordinates and global attributes are written by xarray (``study.dataset.coords_of``,
``scalar_coords``, ``global_attrs``); the data variables are created with netCDF4 and filled
block by block, so memory holds a few chunks whatever the size of the cube.

How the file maps to CF (``Conventions = "CF-1.8"``, checked by ``tests/study/test_cf_checkers.py``):

- every axis is a coordinate variable with ``units`` and ``long_name``; a label axis (``scene``,
  ``integrator``) is a character array named like its dimension (CF's string-valued coordinate,
  stored as ``char``), which xarray decodes to an index of labels: ``ds.sel(scene="slipping")``;
  the numbers of each label (a scene's ``mu``, ``k_r``, ``k_d``) are auxiliary coordinates along it;
- every numeric scalar setting and physical parameter of the run is a scalar coordinate variable
  (``omega2 = 65``), so that files of runs differing in one setting combine along it
  (``xr.open_mfdataset(paths, combine="nested", concat_dim="omega2")``); the ``param_*`` and
  ``setting_*`` global attributes record the same values as the run's provenance;
- each data variable names its auxiliary and scalar coordinates in its own ``coordinates``
  attribute, and the integration status of its lanes in ``ancillary_variables = "status"``
  where the study has one (flags: ``flag_values``, ``flag_meanings``);
- the storage chunks hold about a million values (1-8 MB) whatever the compute chunks were
  (``study.plan.storage_chunks``), which is what ``xr.open_dataset(path, chunks={})`` hands to dask.
"""

from __future__ import annotations

import itertools

import netCDF4
import numpy as np
import xarray as xr

from rimroll.study import io
from rimroll.study.dataset import coords_of, scalar_coords
from rimroll.study.derived_variables import derived_variables
from rimroll.study.parts import PartStore
from rimroll.study.plan import Plan
from rimroll.study.registry import UserError

STATUS = "status"  # the variable of the lanes' integration status, where a study has one


def assemble(plan: Plan, store: PartStore, path, attrs: dict) -> None:
    """Write ``path`` from the parts of every chunk of ``plan`` (all must be present).

    The temporary file lives in the parts folder, so one left by a kill is cleaned with it."""
    coords = coords_of(plan.axes)
    taken = {*coords, *(v.name for v in plan.study.variables)}
    coords.update(scalar_coords(plan.study, plan.settings, tuple(a.name for a in plan.outer), taken))
    skeleton = xr.Dataset(coords=coords, attrs=attrs)
    encoding = {name: _coord_encoding(skeleton[name]) for name in skeleton.coords}
    store.dir.mkdir(parents=True, exist_ok=True)
    with io.atomic_path(path, tmp_dir=store.dir) as tmp:  # a SIGKILL leaves it with the parts
        skeleton.to_netcdf(tmp, engine="netcdf4", format="NETCDF4", encoding=encoding)
        with netCDF4.Dataset(tmp, "a") as nc:
            if "coordinates" in nc.ncattrs():  # xarray's place for coordinates no variable used yet
                nc.delncattr("coordinates")
            variables = _create_variables(plan, nc, skeleton)
            _fill(plan, store, variables)
        if plan.study.derive is not None:
            _add_derived(plan, tmp, skeleton)
        io.seal(tmp)  # the checksum of every variable: a damaged result is never reused (study.existing_result)


def _coord_encoding(coord: xr.DataArray) -> dict:
    if coord.dtype.kind in "UO":
        return {"dtype": "S1", "_FillValue": None, **io.COMPRESSION}  # labels as a CF character array
    if coord.ndim == 0:
        return {"_FillValue": None}
    return dict(io.COMPRESSION, _FillValue=None)


def coordinates_of(dims: tuple, skeleton: xr.Dataset) -> str:
    """The CF ``coordinates`` attribute of a variable over ``dims``: the auxiliary and scalar
    coordinates whose dimensions it has."""
    return " ".join(name for name, c in skeleton.coords.items()
                    if name not in skeleton.dims and set(c.dims) <= set(dims))


def _create_variables(plan: Plan, nc, skeleton: xr.Dataset) -> dict:
    """The study's variables in ``nc`` (empty), with their CF attributes and storage chunks."""
    dims = tuple(a.name for a in plan.axes)
    outer_dims = dims[: len(plan.outer)]
    names = {v.name for v in plan.study.variables}
    variables = {}
    for v in plan.study.variables:
        vdims = outer_dims if v.outer else dims
        shape = tuple(nc.dimensions[d].size for d in vdims)
        chunks = shape if v.outer else plan.storage
        kind = np.dtype(v.dtype)
        fill = np.nan if kind.kind == "f" else False
        var = nc.createVariable(v.name, kind, vdims, fill_value=fill, chunksizes=chunks or None,
                                zlib=bool(vdims), complevel=io.COMPRESSION["complevel"],
                                fletcher32=bool(vdims))
        var.set_auto_maskandscale(False)
        attrs = dict(v.attrs)
        if coordinates := coordinates_of(vdims, skeleton):
            attrs["coordinates"] = coordinates
        if STATUS in names and v.name != STATUS and not v.outer:
            attrs["ancillary_variables"] = STATUS
        var.setncatts(attrs)
        variables[v.name] = (var, v.outer)
    return variables


def _fill(plan: Plan, store: PartStore, variables: dict) -> None:
    """Write every part into ``variables``, one block of whole storage chunks at a time: a block is
    the larger of a storage chunk and a compute chunk along each dimension (one is a multiple of the
    other), so every part is read once and every storage chunk written once."""
    n_outer = len(plan.outer)
    unit = tuple(max(s, c) for s, c in zip(plan.storage, plan.nc_chunks))
    per_unit = tuple(-(-u // c) for u, c in zip(unit, plan.nc_chunks))  # compute chunks per block, per dimension
    shape = plan.shape
    for start in itertools.product(*(range(0, n, u) for n, u in zip(shape, unit))):
        block = tuple(slice(s, min(s + u, n)) for s, u, n in zip(start, unit, shape))
        buffers = {name: np.full(tuple(b.stop - b.start for b in (block[:n_outer] if outer else block)),
                                 np.nan if var.dtype.kind == "f" else 0, dtype=var.dtype)
                   for name, (var, outer) in variables.items()}
        first = tuple(s // c for s, c in zip(start, plan.nc_chunks))
        ranges = (range(f, min(f + p, count)) for f, p, count in zip(first, per_unit, plan.counts))
        for index in itertools.product(*ranges):
            k = int(np.ravel_multi_index(index, plan.counts))
            arrays = store.load(k, plan.expected(k))
            if arrays is None:
                raise UserError(f"part {store.path(k)} vanished or was damaged during the run (was the parts "
                                f"folder removed?); {store.count()} of {plan.n_chunks} chunks saved; rerun the "
                                "same command to recompute the missing ones")
            region = tuple(slice(r.start - b.start, r.stop - b.start) for r, b in zip(plan.region(k), block))
            for name, (_, outer) in variables.items():
                buffers[name][region[:n_outer] if outer else region] = arrays[name]
        for name, (var, outer) in variables.items():
            var[block[:n_outer] if outer else block] = buffers[name]


def _add_derived(plan: Plan, tmp, skeleton: xr.Dataset) -> None:
    """Append the study's derived variables (``Study.derive`` on the whole grid) to ``tmp``."""
    with xr.open_dataset(tmp, engine="netcdf4") as ds:  # lazy: derive reads what it needs
        extra = derived_variables(plan.study, ds)
    dims_all = tuple(a.name for a in plan.axes)
    with netCDF4.Dataset(tmp, "a") as nc:
        for name, (dims, values, attrs) in extra.items():
            for d, n in zip(dims, values.shape):  # a new dimension (with its coordinate, or a ragged array's)
                if d not in nc.dimensions:
                    nc.createDimension(d, n)
            chunks = plan.storage if dims == dims_all else None
            var = nc.createVariable(name, values.dtype, dims, chunksizes=chunks, zlib=bool(dims), fletcher32=bool(dims),
                                    complevel=io.COMPRESSION["complevel"])
            var.set_auto_maskandscale(False)
            if dims != (name,) and (coordinates := coordinates_of(dims, skeleton)):
                attrs = {**attrs, "coordinates": coordinates}
            var.setncatts(attrs)
            var[...] = values

