# The library's modules (the folders of src/ugvr and include/ugvr) and the modules each one may include, besides its
# own. docs/architecture.md draws this graph. The build checks every #include "ugvr/MODULE/..." against it
# (check_module_deps.cmake): an include across a line not listed here fails the build, so the layering stays what the
# table says; change the table (and the picture) on purpose when a module really needs another.
set(UGVR_MODULES core grid io gen refine report store octree gpu render view api mpi)
set(UGVR_DEPS_core "")
set(UGVR_DEPS_grid core)
set(UGVR_DEPS_io core grid)
set(UGVR_DEPS_gen core grid io)
set(UGVR_DEPS_refine core grid io)
set(UGVR_DEPS_report core grid store)
set(UGVR_DEPS_store core grid)
set(UGVR_DEPS_octree core grid io store)
set(UGVR_DEPS_gpu core)
set(UGVR_DEPS_render core grid io gpu store)
set(UGVR_DEPS_view core grid io gpu store octree render)
set(UGVR_DEPS_api core grid io store octree render)
set(UGVR_DEPS_mpi core grid io gpu store octree render)
