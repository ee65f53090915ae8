#!/usr/bin/python3
"""Two brick stores (.ugvr) of one mesh compared node by node (issue 24: out-of-core stores at two memory budgets).

Usage: bench/compare_stores.py A.ugvr B.ugvr
Prints one JSON object: each store's node count and boundary section (bytes, triangles), and how many nodes differ in
each of: child mask, valid fraction, field min / max, error_max, error_rms, the brick's block (bytes as written: mask
and samples), the transfer-function error entry; error and entry differences split into leaves and interior nodes.
Nodes are matched by place (level, i, j, k): two builds may number them differently. All zero: the same tree, bricks
bit for bit and errors. Reads the layout of src/ugvr/store/brick_store_format.h (header, tf-error and boundary header
records, node table, blocks); a store with time compares its first step only. Exit status 0 when nothing differs
but the boundary section.
"""
import json
import struct
import sys

NO_NODE = 0xFFFFFFFFFFFFFFFF
FIELD_NAMES = ["min", "max", "error_max", "error_rms", "block_size", "block_crc", "block", "tf_entry"]


def load(path):
    b = open(path, "rb").read()
    if b[:8] != b"\x89UBS\r\n\x1a\n":
        sys.exit(f"{path}: not a brick store")
    _version, _header_size, _r, fields, record_size = struct.unpack_from("<IIIII", b, 8)
    count, table, _size = struct.unpack_from("<QQQ", b, 144)
    tf_offset, _tf_size, tf_entry = struct.unpack_from("<QQI", b, 176)
    boundary_offset, boundary_size, boundary_triangles = struct.unpack_from("<QQI", b, 200)
    nodes = {}
    for n in range(count):
        at = table + n * record_size
        _parent, first_child, brick, i, j, k, level, mask, _r0, valid = struct.unpack_from("<QQQIIIBBHf", b, at)
        per_field = []
        offset = brick
        for f in range(fields):
            lo, hi, error_max, error_rms, size, crc = struct.unpack_from("<ffffII", b, at + 48 + 24 * f)
            block = b[offset:offset + size]
            offset += size
            e = (n * fields + f) * tf_entry
            tf = b[tf_offset + e:tf_offset + e + tf_entry] if tf_offset else b""
            per_field.append((lo, hi, error_max, error_rms, size, crc, block, tf))
        nodes[(level, i, j, k)] = (first_child == NO_NODE, mask, valid, per_field)
    return {"nodes": count, "boundary_bytes": boundary_size, "boundary_triangles": boundary_triangles,
            "by_place": nodes}


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    a, b = load(sys.argv[1]), load(sys.argv[2])
    differ = {}

    def count(what):
        differ[what] = differ.get(what, 0) + 1

    for place, (leaf, mask, valid, fields) in a["by_place"].items():
        other = b["by_place"].get(place)
        if other is None:
            count("only in A")
            continue
        if mask != other[1]:
            count("child_mask")
        if valid != other[2]:
            count("valid_fraction")
        for fa, fb in zip(fields, other[3]):
            for name, x, y in zip(FIELD_NAMES, fa, fb):
                if x != y:
                    count(name + (" (leaf)" if leaf else " (interior)"))
    for place in b["by_place"]:
        if place not in a["by_place"]:
            count("only in B")
    out = {"a": sys.argv[1], "b": sys.argv[2], "nodes": [a["nodes"], b["nodes"]],
           "boundary_triangles": [a["boundary_triangles"], b["boundary_triangles"]],
           "boundary_bytes": [a["boundary_bytes"], b["boundary_bytes"]], "nodes_differing": differ}
    print(json.dumps(out))
    sys.exit(0 if not differ else 1)


main()
