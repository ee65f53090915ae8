#!/usr/bin/env python3
"""Instrumentation variants of the LOD shader's face pass (issue 25; bench/README.md, "Exact boundary: frame cost").

llvmpipe's `perf` profile shows the JIT'd shader as one blob, so the face pass is profiled by variants: copies of
the shader directory with one part of the pass removed or stubbed, timed against each other with
bench/run_faces_ab.sh (same binary, same store). Most variants draw WRONG images: they are for timing only.

Usage: bench/faces_variants.py SHADER_DIR OUT_ROOT VARIANT...   writes OUT_ROOT/VARIANT for each
  off        FACES forced to 0: the stencil alone (what main drew before the faces)
  plumb      the face pass never triggered (fpend false): the cost of its code being there
  notrigger  the trigger removed from the sample loop
  nopass     the trigger and the second pass, but no face test (the state stays with the stencil)
  nfcheap    node_faces replaced by a stub that sets a state and at most one crossing (no walk, no triangle)
  noside     no nearest-face rule (side_of_faces) where the line meets no face
  nowalk     nodes over the cap treated as having no faces (no walk through descendants or virtual nodes)
  tri4       at most 4 triangles of a cell tested
"""
import os
import shutil
import sys

VARIANTS = {
    'off': [('#ifndef FACES\n#define FACES 0', '#undef FACES\n#define FACES 0\n#if 0')],
    'plumb': [('bool fpend = face_node[node].y != 0u;', 'bool fpend = false;')],
    'notrigger': [('if (!crossings && fpend && ((vb.g > 0.001', 'if (false && fpend && ((vb.g > 0.001')],
    'nopass': [('fstate = node_faces(node, lo, size, base, dir, inv_dir, tstart, t_exit, u_nudge);', 'fstate = -1;')],
    'nfcheap': [('fstate = node_faces(node, lo, size, base, dir, inv_dir, tstart, t_exit, u_nudge);',
                 'fstate = int(face_node[node].y & 1u); g_nh = int(face_node[node].x & 1u); g_fh[0] = tstart; '
                 'g_fs[0] = 1.0;')],
    'noside': [('if (state < 0 && first_fe.y > 0u) state = side_of_faces',
                'if (false) state = side_of_faces')],
    'nowalk': [('  if (fe.y == 0u) return -1;', '  if (fe.y == 0u || fe.y == FACE_OVERFLOW) return -1;')],
    'tri4': [('''  for (uint i = 0u; i < fe.y; ++i) {
    uint b = face_ref[fe.x + i] * 9u;
    vec3 p0 = vec3(face_tri[b], face_tri[b + 1u], face_tri[b + 2u]);
    vec3 e1''', '''  for (uint i = 0u; i < min(fe.y, 4u); ++i) {
    uint b = face_ref[fe.x + i] * 9u;
    vec3 p0 = vec3(face_tri[b], face_tri[b + 1u], face_tri[b + 2u]);
    vec3 e1''')],
}


def main():
    if len(sys.argv) < 4 or any(v not in VARIANTS for v in sys.argv[3:]):
        sys.exit(__doc__)
    src, root = sys.argv[1], sys.argv[2]
    text = open(os.path.join(src, 'lod_raycast.comp')).read()
    for name in sys.argv[3:]:
        out = os.path.join(root, name)
        shutil.rmtree(out, ignore_errors=True)
        shutil.copytree(src, out)
        s = text
        for old, new in VARIANTS[name]:
            if s.count(old) != 1:
                sys.exit(f'{name}: the shader no longer has exactly one {old!r}')
            s = s.replace(old, new)
        open(os.path.join(out, 'lod_raycast.comp'), 'w').write(s)
        print(out)


if __name__ == '__main__':
    main()
