#!/usr/bin/env python3
"""Instrumentation variants of the LOD shader's face pass (issue 25; bench/README.md, "Exact boundary: frame cost").

llvmpipe's `perf` profile shows the JIT'd shader as one blob, so the face pass is profiled by variants: copies of
the shader directory with one part of the pass removed or stubbed, timed against each other with
bench/run_faces_ab.sh (same binary, same store). Most variants draw WRONG images: they are for timing only.

Usage: bench/faces_variants.py SHADER_DIR OUT_ROOT VARIANT...   writes OUT_ROOT/VARIANT for each
  off        FACES forced to 0: the stencil alone (what main drew before the faces)
  plumb      the face pass never triggered (fpend false): the cost of its code being there
  never      the trigger impossible at run time (the compiler cannot tell): the face code there, entered by no ray;
             what its mere presence costs llvmpipe (masked code runs anyway, a loop's body at least once)
  batch1     the face passes not batched (main's loop runs them at every node step, as before the batches)
  notrigger  the trigger removed from the sample loop
  nopass     the trigger and the second pass, but no face test (the state stays with the stencil)
  tailcut    the second pass ends at the node's last crossing (the rest of the node not drawn): what handing that
             stretch to anything else could save at most
  nfcheap    node_faces replaced by a stub that sets a state and at most one crossing (no walk, no triangle)
  noside     no nearest-face rule (side_of_faces) where the line meets no face
  nowalk     nodes over the cap treated as having no faces (no walk through descendants or virtual nodes)
  tri4       at most 4 triangles of a cell tested
Counting variants (draw the right image; the frame's `samples` and `bricks_entered` in `render --stats` are replaced
by two counts, c0 and c1, summed over the rays; render one frame):
  count-entries   c0: node entries into nodes with faces, c1: face passes (node_faces calls)
  count-kinds     face passes at c0: a node on one plane (FACE_PLANE), c1: a node over the cap (a walk); the rest of
                  the passes (count-entries' c1 minus both) at a node that lists its triangles
  count-calls     c0: cells whose triangles are tested (cell_faces), c1: cells clipped at their plane (plane_faces)
  count-planes12  cell_faces calls whose triangles lie on c0: one plane (not covering the section), c1: two planes
  count-planes34  the same, c0: three planes, c1: four or more (1e-4 apart in normal and offset, normalised)
  count-rounds    per SIMD vector (GL_ARB_shader_ballot: one lane of each vector counts), c0: rounds of the first
                  pass's sample loop, c1: of the second pass's (what llvmpipe runs: a round costs the vector whether
                  one of its rays or all eight take it)
  count-steps     per SIMD vector, c0: node steps of main's loop, c1: batches (each runs the face pass's code once)
Patch variants (bench/faces_variants/NAME.diff, the variants tried for issue 25 in helper facecost's session; made
against the shaders of the commit that added them and applied with `patch`, which may need a hand where the shader
has moved since):
  handback   the second pass hands the rest of the node back to the first pass after the node's last crossing
             (same image bits)
  planefirst a node on one plane clipped in the first pass, no face pass (the image differs by float rounding)
  vote       the rays of a SIMD vector leave a batch together when one stops (GL_ARB_shader_group_vote; same bits)
"""
import subprocess
import os
import shutil
import sys

VARIANTS = {
    'off': [('#ifndef FACES\n#define FACES 0', '#undef FACES\n#define FACES 0\n#if 0')],
    'plumb': [('bool fpend = face_node[node].y != 0u;', 'bool fpend = false;')],
    'never': [('if (!crossings && fpend && ((vb.g > 0.001 && vb.g < 0.999) || (!first && (vb.g >= 0.5) != (va.g >= 0.5))))',
               'if (!crossings && fpend && vb.g > 2.0 + u_nudge)')],
    'batch1': [('#define LOD_FACE_BATCH_NODES 16 ', '#define LOD_FACE_BATCH_NODES 1 ')],
    'notrigger': [('if (!crossings && fpend && ((vb.g > 0.001', 'if (false && fpend && ((vb.g > 0.001')],
    'nopass': [('fstate = node_faces(node, lo, size, base, dir, inv_dir, tstart, t_exit, u_nudge);', 'fstate = -1;')],
    'tailcut': [('      fnext = fj < g_nh ? g_fh[fj] : 3.0e38;\n    }\n',
                 '      fnext = fj < g_nh ? g_fh[fj] : 3.0e38;\n    }\n'
                 '    if (crossings && fstate >= 0 && fj == g_nh) break;\n')],
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

# The counting variants' shared part: two counters, and the number of distinct planes of a cell's triangles.
COUNT_COMMON = [('int g_nh;\n', '''int g_nh;
uint g_c0 = 0u, g_c1 = 0u;
int distinct_planes(uvec2 fe) {
  vec4 pl[8];
  int np = 0;
  for (uint i = 0u; i < fe.y; ++i) {
    uint b = face_ref[fe.x + i] * 9u;
    vec3 p0 = vec3(face_tri[b], face_tri[b + 1u], face_tri[b + 2u]);
    vec3 n = normalize(cross(vec3(face_tri[b + 3u], face_tri[b + 4u], face_tri[b + 5u]) - p0,
                             vec3(face_tri[b + 6u], face_tri[b + 7u], face_tri[b + 8u]) - p0));
    vec4 q = vec4(n, dot(n, p0));
    bool found = false;
    for (int k = 0; k < np; ++k) found = found || distance(pl[k], q) < 1e-4;
    if (!found && np < 8) pl[np++] = q;
  }
  return np;
}
'''), ('  atomicAdd(counters[COUNTER_SAMPLES], samples);',
        '  samples = g_c0;\n  bricks = g_c1;\n  atomicAdd(counters[COUNTER_SAMPLES], samples);')]
# Counting per SIMD vector: the first active lane of each vector counts (readFirstInvocationARB).
# Outside the FACES code, so that they apply to the `off` variant too (faces_variants.py OFF_DIR OUT count-rounds).
BALLOT = [('#version 450\n', '#version 450\n#extension GL_ARB_shader_ballot : require\n'),
          ('#include "lod_shared.h"', 'uint g_c0 = 0u, g_c1 = 0u;\nbool lead_lane() { return gl_SubGroupInvocationARB == '
                                      'readFirstInvocationARB(gl_SubGroupInvocationARB); }\n#include "lod_shared.h"'),
          COUNT_COMMON[1]]
CELL_FACES = 'bool cell_faces(uvec2 fe, vec3 o, vec3 d, float t0, float t1, float eps, inout int state) {\n'
PLANE_FACES = 'bool plane_faces(uint at, vec3 o, vec3 d, float t0, float t1, inout int state) {\n'
NODE_FACES = '  int fstate = node_faces(node, lo, size, base, dir, inv_dir, tstart, t_exit, u_nudge);\n'
VARIANTS.update({
    'count-entries': COUNT_COMMON + [
        ('  bool fpend = face_node[node].y != 0u;\n',
         '  bool fpend = face_node[node].y != 0u;\n  if (fpend && !faces_pass) ++g_c0;\n'),
        (NODE_FACES, '  ++g_c1;\n' + NODE_FACES)],
    'count-kinds': COUNT_COMMON + [
        (NODE_FACES, '  if (face_node[node].y == FACE_PLANE) ++g_c0;\n'
                     '  if (face_node[node].y == FACE_OVERFLOW) ++g_c1;\n' + NODE_FACES)],
    'count-calls': COUNT_COMMON + [(CELL_FACES, CELL_FACES + '  ++g_c0;\n'),
                                   (PLANE_FACES, PLANE_FACES + '  ++g_c1;\n')],
    'count-planes12': COUNT_COMMON + [
        (CELL_FACES, CELL_FACES + '  int np = distinct_planes(fe);\n  if (np == 1) ++g_c0;\n  if (np == 2) ++g_c1;\n')],
    'count-planes34': COUNT_COMMON + [
        (CELL_FACES, CELL_FACES + '  int np = distinct_planes(fe);\n  if (np == 3) ++g_c0;\n  if (np >= 4) ++g_c1;\n')],
    'count-rounds': BALLOT + [
        ('    ++samples;\n    bool first = sb == tstart;\n',
         '    ++samples;\n    if (lead_lane()) {\n      if (crossings) ++g_c1; else ++g_c0;\n    }\n'
         '    bool first = sb == tstart;\n')],
    'count-steps': BALLOT + [
        ('    // Point location: descend from the root to the cut node (or empty region) just past t.\n',
         '    // Point location: descend from the root to the cut node (or empty region) just past t.\n'
         '    if (lead_lane()) ++g_c0;\n'),
        ('  bool f_pending = false', '  if (lead_lane()) ++g_c1;\n  bool f_pending = false')],
})
PATCHES = ('handback', 'planefirst', 'vote')


def main():
    if len(sys.argv) < 4 or any(v not in VARIANTS and v not in PATCHES for v in sys.argv[3:]):
        sys.exit(__doc__)
    src, root = sys.argv[1], sys.argv[2]
    text = open(os.path.join(src, 'lod_raycast.comp')).read()
    for name in sys.argv[3:]:
        out = os.path.join(root, name)
        shutil.rmtree(out, ignore_errors=True)
        shutil.copytree(src, out)
        if name in PATCHES:
            diff = os.path.join(os.path.dirname(os.path.abspath(__file__)), 'faces_variants', name + '.diff')
            with open(diff) as f:
                subprocess.run(['patch', '-s', '-p1', '-d', out], stdin=f, check=True)
            print(out)
            continue
        s = text
        for old, new in VARIANTS[name]:
            if s.count(old) != 1:
                sys.exit(f'{name}: the shader no longer has exactly one {old!r}')
            s = s.replace(old, new)
        open(os.path.join(out, 'lod_raycast.comp'), 'w').write(s)
        print(out)


if __name__ == '__main__':
    main()
