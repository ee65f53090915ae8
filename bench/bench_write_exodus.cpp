// Writes a mesh of one cell type (hexahedra or tetrahedra) as an Exodus II file (netCDF-3, 64-bit offset) of BLOCKS
// element blocks of consecutive cells, with the mesh's first vertex field as a nodal variable at one time step: the
// large Exodus input of the MPI part-read benchmark (bench/run_mpi_part_read.sh INPUT=...; the real Exodus files in
// /work/shared/data hold a few thousand cells). Usage: bench_write_exodus IN OUT.e BLOCKS
#include <netcdf.h>

#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "ugvr/core/error.h"
#include "ugvr/io/reader.h"

namespace {

void check(int status, const char* what) {
  if (status != NC_NOERR) throw ugvr::Error(std::string(what) + ": " + nc_strerror(status));
}

void write_exodus(const ugvr::Block& block, const std::string& path, int blocks) {
  const auto& mesh = std::get<ugvr::UnstructuredMesh>(block.grid);
  const uint64_t cells = mesh.cell_count();
  const ugvr::CellType type = mesh.cell_types.at(0);
  for (const ugvr::CellType t : mesh.cell_types)
    if (t != type) throw ugvr::Error("the mesh mixes cell types: one type per file here");
  if (type != ugvr::CellType::Hexahedron && type != ugvr::CellType::Tetra)
    throw ugvr::Error("hexahedra or tetrahedra only");
  const size_t per = type == ugvr::CellType::Hexahedron ? 8 : 4;
  const ugvr::Field* nodal = nullptr;
  for (const ugvr::Field& f : block.fields)
    if (f.association() == ugvr::Association::Vertex && !nodal) nodal = &f;
  const std::string temp = path + ".tmp";
  int nc = -1;
  check(nc_create(temp.c_str(), NC_CLOBBER | NC_64BIT_OFFSET, &nc), "create");
  int d_dim, d_nodes, d_elem, d_blk, d_time, d_str, d_one;
  check(nc_def_dim(nc, "num_dim", 3, &d_dim), "num_dim");
  check(nc_def_dim(nc, "num_nodes", mesh.point_count(), &d_nodes), "num_nodes");
  check(nc_def_dim(nc, "num_elem", cells, &d_elem), "num_elem");
  check(nc_def_dim(nc, "num_el_blk", size_t(blocks), &d_blk), "num_el_blk");
  check(nc_def_dim(nc, "time_step", NC_UNLIMITED, &d_time), "time_step");
  check(nc_def_dim(nc, "len_name", 33, &d_str), "len_name");
  check(nc_def_dim(nc, "num_nod_var", 1, &d_one), "num_nod_var");
  int v_xyz[3], v_time, v_prop, v_names = -1, v_vals = -1;
  const char* axes[3] = {"coordx", "coordy", "coordz"};
  for (int a = 0; a < 3; ++a) check(nc_def_var(nc, axes[a], NC_DOUBLE, 1, &d_nodes, &v_xyz[a]), axes[a]);
  check(nc_def_var(nc, "time_whole", NC_DOUBLE, 1, &d_time, &v_time), "time_whole");
  check(nc_def_var(nc, "eb_prop1", NC_INT, 1, &d_blk, &v_prop), "eb_prop1");
  std::vector<int> v_connect(static_cast<size_t>(blocks));
  std::vector<uint64_t> first(static_cast<size_t>(blocks) + 1);
  for (int b = 0; b <= blocks; ++b) first[size_t(b)] = cells * uint64_t(b) / uint64_t(blocks);
  const char* elem_type = per == 8 ? "HEX8" : "TETRA4";
  for (int b = 0; b < blocks; ++b) {
    const std::string n = std::to_string(b + 1);
    int dims[2];
    check(nc_def_dim(nc, ("num_el_in_blk" + n).c_str(), first[size_t(b) + 1] - first[size_t(b)], &dims[0]), "blk");
    check(nc_def_dim(nc, ("num_nod_per_el" + n).c_str(), per, &dims[1]), "per");
    check(nc_def_var(nc, ("connect" + n).c_str(), NC_INT, 2, dims, &v_connect[size_t(b)]), "connect");
    check(nc_put_att_text(nc, v_connect[size_t(b)], "elem_type", std::string(elem_type).size(), elem_type), "type");
  }
  if (nodal) {
    const int name_dims[2] = {d_one, d_str}, val_dims[2] = {d_time, d_nodes};
    check(nc_def_var(nc, "name_nod_var", NC_CHAR, 2, name_dims, &v_names), "name_nod_var");
    check(nc_def_var(nc, "vals_nod_var1", NC_FLOAT, 2, val_dims, &v_vals), "vals_nod_var1");
  }
  check(nc_enddef(nc), "enddef");
  std::vector<double> xyz(mesh.point_count());
  for (int a = 0; a < 3; ++a) {
    for (size_t i = 0; i < xyz.size(); ++i) xyz[i] = double((&mesh.points[i].x)[a]);
    check(nc_put_var_double(nc, v_xyz[a], xyz.data()), axes[a]);
  }
  const size_t zero = 0, one = 1;
  const double t0 = 0;
  check(nc_put_vara_double(nc, v_time, &zero, &one, &t0), "time_whole");
  std::vector<int> ids(static_cast<size_t>(blocks));
  for (int b = 0; b < blocks; ++b) ids[size_t(b)] = b + 1;
  check(nc_put_var_int(nc, v_prop, ids.data()), "eb_prop1");
  for (int b = 0; b < blocks; ++b) {
    std::vector<int> conn;
    conn.reserve((first[size_t(b) + 1] - first[size_t(b)]) * per);
    for (uint64_t c = first[size_t(b)]; c < first[size_t(b) + 1]; ++c)
      for (const uint32_t v : mesh.cell(c)) conn.push_back(int(v) + 1);  // VTK and Exodus hex/tet orders agree
    check(nc_put_var_int(nc, v_connect[size_t(b)], conn.data()), "connect");
  }
  if (nodal) {
    char name[33] = {};
    std::snprintf(name, sizeof name, "%s", nodal->name().c_str());
    check(nc_put_var_text(nc, v_names, name), "name_nod_var");
    std::vector<float> values(mesh.point_count());
    for (size_t i = 0; i < values.size(); ++i) values[i] = float(nodal->scalar(i, 0));
    const size_t start[2] = {0, 0}, count[2] = {1, values.size()};
    check(nc_put_vara_float(nc, v_vals, start, count, values.data()), "vals_nod_var1");
  }
  check(nc_close(nc), "close");
  if (std::rename(temp.c_str(), path.c_str()) != 0) throw ugvr::Error("cannot rename " + temp + " to " + path);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 4) {
    std::fprintf(stderr, "usage: %s IN OUT.e BLOCKS\n", argv[0]);
    return 2;
  }
  const int blocks = std::atoi(argv[3]);
  if (blocks < 1 || blocks > 4096) {
    std::fprintf(stderr, "BLOCKS must be 1 to 4096\n");
    return 2;
  }
  try {
    const ugvr::Dataset ds = ugvr::read_dataset(std::vector<std::string>{argv[1]});
    if (ds.blocks.size() != 1 || !std::holds_alternative<ugvr::UnstructuredMesh>(ds.blocks[0].grid))
      throw ugvr::Error(std::string(argv[1]) + ": one unstructured block expected");
    write_exodus(ds.blocks[0], argv[2], blocks);
    std::printf("%s: %d blocks\n", argv[2], blocks);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  return 0;
}
