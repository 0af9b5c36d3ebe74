#!/usr/bin/env python3
"""Independent check of peridyn's Exodus writer.

Usage: scripts/check_exodus.py <dir>

<dir> holds roundtrip.e and roundtrip.json, written by
`PERIDYN_KEEP_FIXTURES=<dir> cargo test --test exodus_roundtrip`. The .e file is opened
with netCDF4 (the reference netCDF library) and with meshio (its Exodus reader), and every
item of the JSON is checked with each. Prints one line per check and `N passed, M failed`;
the exit status is non-zero if anything failed.
"""

import json
import sys
from pathlib import Path

import numpy as np

results = []


def check(label, condition, detail=""):
    ok = bool(condition)
    results.append(ok)
    detail = "" if ok else str(detail)
    print(f"{'PASS' if ok else 'FAIL'} {label}" + (f": {detail}" if detail else ""))


def names(var):
    """A netCDF char array [n][len] as a list of Python strings."""
    raw = np.asarray(var[:])
    return ["".join(c.decode() for c in row if c not in (b"", b"\x00")).strip() for row in raw]


def check_netcdf(path, spec):
    import netCDF4

    with netCDF4.Dataset(path) as nc:
        nc.set_auto_mask(False)
        check("netCDF4: file format is 64-bit offset", nc.file_format == "NETCDF3_64BIT_OFFSET", nc.file_format)
        check("netCDF4: title", nc.getncattr("title") == spec["title"], nc.getncattr("title"))
        check("netCDF4: num_nodes", len(nc.dimensions["num_nodes"]) == spec["num_nodes"])
        coords = np.column_stack([nc["coordx"][:], nc["coordy"][:], nc["coordz"][:]])
        check("netCDF4: coordinates", np.array_equal(coords, np.array(spec["coordinates"])))
        check("netCDF4: node_num_map", list(nc["node_num_map"][:]) == spec["node_ids"])
        check("netCDF4: block ids", list(nc["eb_prop1"][:]) == [b["id"] for b in spec["blocks"]])
        check("netCDF4: block names", names(nc["eb_names"]) == [b["name"] for b in spec["blocks"]], names(nc["eb_names"]))
        for i, block in enumerate(spec["blocks"], start=1):
            connect = nc[f"connect{i}"]
            check(f"netCDF4: block {block['id']} size", connect.shape == (block["size"], 1), connect.shape)
            check(f"netCDF4: block {block['id']} elem_type SPHERE", connect.getncattr("elem_type") == "SPHERE")
            check(f"netCDF4: block {block['id']} connectivity", list(connect[:, 0]) == block["nodes"])
        check("netCDF4: node set ids", list(nc["ns_prop1"][:]) == [s["id"] for s in spec["node_sets"]])
        check("netCDF4: node set names", names(nc["ns_names"]) == [s["name"] for s in spec["node_sets"]], names(nc["ns_names"]))
        for k, node_set in enumerate(spec["node_sets"], start=1):
            check(f"netCDF4: node set {node_set['name']} members", list(nc[f"node_ns{k}"][:]) == node_set["nodes"])
        check("netCDF4: nodal variable names", names(nc["name_nod_var"]) == spec["nodal_variables"])
        check("netCDF4: element variable names", names(nc["name_elem_var"]) == spec["element_variables"])
        check("netCDF4: global variable names", names(nc["name_glo_var"]) == spec["global_variables"])
        check("netCDF4: elem_var_tab all defined", np.all(nc["elem_var_tab"][:] == 1))
        check("netCDF4: times", list(nc["time_whole"][:]) == spec["times"], list(nc["time_whole"][:]))
        for s in spec["samples"]:
            step = s["step"]
            if s["kind"] == "nodal":
                k = spec["nodal_variables"].index(s["variable"]) + 1
                got = nc[f"vals_nod_var{k}"][step, s["node"]]
                where = f"node {s['node']}"
            elif s["kind"] == "element":
                k = spec["element_variables"].index(s["variable"]) + 1
                got = nc[f"vals_elem_var{k}eb{s['block_index'] + 1}"][step, s["element"]]
                where = f"block {s['block_id']} element {s['element']}"
            else:
                k = spec["global_variables"].index(s["variable"])
                got = nc["vals_glo_var"][step, k]
                where = "global"
            check(f"netCDF4: {s['variable']} step {step} {where}", got == s["value"], f"{got!r} != {s['value']!r}")


def check_meshio(path, spec):
    import meshio

    mesh = meshio.read(path, file_format="exodus")
    check("meshio: points", np.array_equal(mesh.points, np.array(spec["coordinates"])))
    check("meshio: one cell block per element block", len(mesh.cells) == len(spec["blocks"]), len(mesh.cells))
    for cells, block in zip(mesh.cells, spec["blocks"]):
        check(f"meshio: block {block['id']} is vertex cells", cells.type == "vertex", cells.type)
        check(f"meshio: block {block['id']} connectivity", list(cells.data[:, 0] + 1) == block["nodes"])
    for node_set in spec["node_sets"]:
        got = mesh.point_sets.get(node_set["name"])
        check(f"meshio: point set {node_set['name']}", got is not None and list(np.asarray(got) + 1) == node_set["nodes"], got)
    # meshio reads only the first time step; it groups <name>X/Y/Z into one vector field.
    for s in spec["samples"]:
        if s["step"] != 0 or s["kind"] == "global":
            continue
        name = s["variable"]
        if s["kind"] == "nodal":
            if name in mesh.point_data:
                got = mesh.point_data[name][s["node"]]
            else:
                got = mesh.point_data[name[:-1]][s["node"], "XYZ".index(name[-1])]
            where = f"node {s['node']}"
        else:
            got = mesh.cell_data[name][s["block_index"]][s["element"]]
            where = f"block {s['block_id']} element {s['element']}"
        check(f"meshio: {name} step 0 {where}", got == s["value"], f"{got!r} != {s['value']!r}")


def main():
    if len(sys.argv) != 2:
        print(__doc__)
        return 2
    directory = Path(sys.argv[1])
    exodus = directory / "roundtrip.e"
    spec = json.loads((directory / "roundtrip.json").read_text())
    for name, checker in (("netCDF4", check_netcdf), ("meshio", check_meshio)):
        try:
            checker(str(exodus), spec)
        except Exception as error:  # a reader rejecting the file is a failure, not a crash
            check(f"{name}: opens and reads {exodus}", False, f"{type(error).__name__}: {error}")
    passed = sum(results)
    failed = len(results) - passed
    print(f"{passed} passed, {failed} failed")
    return 0 if failed == 0 and passed > 0 else 1


if __name__ == "__main__":
    sys.exit(main())
