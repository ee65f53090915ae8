// Mesa's llvmpipe (gallivm) ends every loop of a shader once the shader's loops have taken 65,535 back edges in all
// (LP_MAX_TGSI_LOOP_ITERATIONS): one counter per invocation of the compiled shader, that is per 8 or 16 lanes run in
// lockstep, shared by every loop and decremented once per iteration of any of them, set once at the shader's start.
// After that each loop runs its body once and leaves, whatever its condition: a walk stops after one more cell, an
// entry search after one more triangle. Nothing reports it. A GPU has no such limit. The cell walk of a large mesh
// reaches it: a ray whose tile lists 48,843 boundary triangles (faces seen edge-on, 30M tetrahedra at 1024²) spends
// it in two entry searches, and a long walk (about 20 back edges a cell) in a few thousand cells.
//
// loop_limit_reached(n) tells: called last, with n = 2 from a uniform (so the loop is not unrolled), its loop runs
// twice unless the limit was reached, or is one back edge away. A true answer may be a lane that finished in time
// beside one that did not (they share the counter): the caller redoes the ray elsewhere, which is never wrong.
bool loop_limit_reached(int n) {
  int iterations = 0;
  for (int i = 0; i < n; ++i) ++iterations;
  return iterations != n;
}
