#include "ugvr/mpi/piece_index.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>

#include "ugvr/core/error.h"
#include "ugvr/core/file.h"
#include "ugvr/core/json_file.h"

namespace ugvr {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr const char* kFormat = "ugvr-pieces";

// A coordinate; infinite ones (the kd cells' outer faces) as null, which JSON has and infinity it has not.
nlohmann::ordered_json coord_json(double v) { return std::isfinite(v) ? nlohmann::ordered_json(v) : nullptr; }

nlohmann::ordered_json box_json(const Bounds& b) {
  nlohmann::ordered_json lo = nlohmann::ordered_json::array(), hi = nlohmann::ordered_json::array();
  for (double v : {b.lo.x, b.lo.y, b.lo.z}) lo.push_back(coord_json(v));
  for (double v : {b.hi.x, b.hi.y, b.hi.z}) hi.push_back(coord_json(v));
  return {{"lo", lo}, {"hi", hi}};
}

// Reads a JSON index, every failure an Error naming the file and the key.
class IndexReader {
 public:
  explicit IndexReader(std::string path) : path_(std::move(path)) {}
  [[noreturn]] void fail(const std::string& what) const { fail_in(path_, "piece index: " + what); }

  const nlohmann::json& key(const nlohmann::json& j, const char* name, const std::string& where) const {
    if (!j.is_object() || !j.contains(name)) fail((where.empty() ? "" : where + ": ") + "no \"" + name + "\"");
    return j[name];
  }
  double number(const nlohmann::json& j, const std::string& where) const {
    if (!j.is_number()) fail(where + ": not a number");
    return j.get<double>();
  }
  uint64_t count(const nlohmann::json& j, const std::string& where) const {
    if (!j.is_number_unsigned()) fail(where + ": not a non-negative integer");
    return j.get<uint64_t>();
  }
  Vec3d corner(const nlohmann::json& j, double missing, const std::string& where) const {
    if (!j.is_array() || j.size() != 3) fail(where + ": not an array of 3 coordinates");
    double v[3];
    for (size_t i = 0; i < 3; ++i) v[i] = j[i].is_null() ? missing : number(j[i], where);
    return {v[0], v[1], v[2]};
  }
  // `open`: null faces allowed (a kd cell); otherwise a finite, non-empty box.
  Bounds box(const nlohmann::json& j, bool open, const std::string& where) const {
    Bounds b;
    b.lo = corner(key(j, "lo", where), -kInf, where + ".lo");
    b.hi = corner(key(j, "hi", where), kInf, where + ".hi");
    const bool finite = std::isfinite(b.lo.x + b.lo.y + b.lo.z + b.hi.x + b.hi.y + b.hi.z);
    if ((!open && !finite) || b.empty()) fail(where + ": not a valid box");
    return b;
  }

 private:
  std::string path_;
};

// Checks that `node` is a kd subtree whose leaves are pieces [first, first + count) in order; returns count.
int check_subtree(const KdTree& tree, int node, int first, std::vector<int>& seen, const IndexReader& r) {
  if (node < 0 || size_t(node) >= tree.nodes.size()) r.fail("tree: a child index out of range");
  if (seen[size_t(node)]++) r.fail("tree: node " + std::to_string(node) + " is reached twice");
  const KdNode& n = tree.nodes[size_t(node)];
  if (n.axis < 0) {
    if (n.part != first)
      r.fail("tree: the leaves do not list the pieces in order (piece " + std::to_string(n.part) + ")");
    return 1;
  }
  const int left = check_subtree(tree, n.child[0], first, seen, r);
  const int right = check_subtree(tree, n.child[1], first + left, seen, r);
  return left + right;
}

// Appends to `out` (the group tree) the part of `tree` under `node`, whose cell is `box`; returns the new node's index.
// A subtree holding exactly per_group pieces becomes one leaf: group (its first piece) / per_group.
int cut_tree(const KdTree& tree, int node, int per_group, const Bounds& box, KdTree& out) {
  std::vector<int> stack{node};
  int count = 0, lowest = std::numeric_limits<int>::max();
  while (!stack.empty()) {
    const KdNode& m = tree.nodes[size_t(stack.back())];
    stack.pop_back();
    if (m.axis < 0) {
      ++count;
      lowest = std::min(lowest, m.part);
    } else {
      stack.push_back(m.child[0]);
      stack.push_back(m.child[1]);
    }
  }
  const int index = int(out.nodes.size());
  out.nodes.emplace_back();
  const KdNode& n = tree.nodes[size_t(node)];
  if (count == per_group) {
    if (lowest % per_group != 0) fail_in("kd-tree", "a subtree does not start at a rank's first piece");
    out.nodes[size_t(index)].part = lowest / per_group;
    out.boxes[size_t(lowest / per_group)] = box;
    return index;
  }
  if (n.axis < 0 || count < per_group) fail_in("kd-tree", "the pieces do not split evenly among the ranks");
  Bounds left = box, right = box;
  (n.axis == 0 ? left.hi.x : n.axis == 1 ? left.hi.y : left.hi.z) = n.split;
  (n.axis == 0 ? right.lo.x : n.axis == 1 ? right.lo.y : right.lo.z) = n.split;
  const int c0 = cut_tree(tree, n.child[0], per_group, left, out);
  const int c1 = cut_tree(tree, n.child[1], per_group, right, out);
  KdNode& o = out.nodes[size_t(index)];
  o.axis = n.axis;
  o.split = n.split;
  o.child = {c0, c1};
  return index;
}

}  // namespace

std::string PieceIndex::store_path(int k) const {
  const std::filesystem::path store(pieces.at(size_t(k)).store);
  if (store.is_absolute()) return store.string();
  return (std::filesystem::path(path).parent_path() / store).string();
}

bool is_piece_index(const std::string& path) {
  const std::filesystem::path p(path);
  std::string ext = p.extension().string();
  for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
  if (ext != ".json" || !std::filesystem::is_regular_file(p)) return false;
  std::ifstream in(path, std::ios::binary);
  char head[256] = {};
  in.read(head, sizeof head - 1);
  return std::string(head).find(std::string("\"format\": \"") + kFormat + "\"") != std::string::npos;
}

void check_piece_count(int pieces) {
  if (pieces < 1 || pieces > kMaxPieces || (pieces & (pieces - 1)) != 0)
    throw Error("--pieces must be a power of two from 1 to " + std::to_string(kMaxPieces) + " (got " +
                std::to_string(pieces) + ")");
}

PieceIndex read_piece_index(const std::string& path) {
  const nlohmann::json j = read_json_file(path);
  const IndexReader r(path);
  if (!j.is_object() || !j.contains("format") || j["format"] != kFormat)
    r.fail(std::string("no \"format\": \"") + kFormat + "\"");
  const uint64_t version = r.count(r.key(j, "version", ""), "version");
  if (version != uint64_t(kPieceIndexVersion))
    r.fail("version " + std::to_string(version) + " (this ugvr reads version " + std::to_string(kPieceIndexVersion) +
           ")");
  PieceIndex index;
  index.path = path;
  index.bounds = r.box(r.key(j, "bounds", ""), false, "bounds");
  index.root = r.box(r.key(j, "root", ""), false, "root");
  index.brick = uint32_t(r.count(r.key(j, "brick", ""), "brick"));
  index.ghost_margin = r.number(r.key(j, "ghost_margin", ""), "ghost_margin");
  index.ghost_level = int(std::min<uint64_t>(r.count(r.key(j, "ghost_level", ""), "ghost_level"), 1u << 20));
  const nlohmann::json& fields = r.key(j, "fields", "");
  if (!fields.is_array() || fields.empty()) r.fail("fields: not a non-empty array");
  for (size_t f = 0; f < fields.size(); ++f) {
    const std::string where = "fields[" + std::to_string(f) + "]";
    BrickStoreField field;
    const nlohmann::json& name = r.key(fields[f], "name", where);
    if (!name.is_string()) r.fail(where + ".name: not a string");
    field.name = name.get<std::string>();
    const nlohmann::json& assoc = r.key(fields[f], "association", where);
    if (assoc != "vertex" && assoc != "cell") r.fail(where + ".association: not \"vertex\" or \"cell\"");
    field.association = assoc == "vertex" ? Association::Vertex : Association::Cell;
    field.min = r.number(r.key(fields[f], "min", where), where + ".min");
    field.max = r.number(r.key(fields[f], "max", where), where + ".max");
    index.fields.push_back(std::move(field));
  }
  const nlohmann::json& pieces = r.key(j, "pieces", "");
  if (!pieces.is_array()) r.fail("pieces: not an array");
  const int n = int(pieces.size());
  if (n < 1 || n > kMaxPieces || (n & (n - 1)) != 0) r.fail("pieces: the count must be a power of two up to 4096");
  for (int k = 0; k < n; ++k) {
    const std::string where = "pieces[" + std::to_string(k) + "]";
    const nlohmann::json& p = pieces[size_t(k)];
    PieceInfo info;
    const nlohmann::json& store = r.key(p, "store", where);
    if (!store.is_string() || store.get<std::string>().empty()) r.fail(where + ".store: not a file name");
    info.store = store.get<std::string>();
    info.box = r.box(r.key(p, "box", where), true, where + ".box");
    info.cells = r.count(r.key(p, "cells", where), where + ".cells");
    info.ghost_cells = r.count(r.key(p, "ghost_cells", where), where + ".ghost_cells");
    info.store_bytes = r.count(r.key(p, "store_bytes", where), where + ".store_bytes");
    index.pieces.push_back(std::move(info));
  }
  const nlohmann::json& tree = r.key(j, "tree", "");
  if (!tree.is_array() || tree.size() != size_t(2 * n - 1)) r.fail("tree: not an array of 2 * pieces - 1 nodes");
  for (size_t i = 0; i < tree.size(); ++i) {
    const std::string where = "tree[" + std::to_string(i) + "]";
    KdNode node;
    if (tree[i].is_object() && tree[i].contains("piece")) {
      node.part = int(r.count(tree[i]["piece"], where + ".piece"));
      if (node.part >= n) r.fail(where + ".piece: out of range");
    } else {
      const uint64_t axis = r.count(r.key(tree[i], "axis", where), where + ".axis");
      if (axis > 2) r.fail(where + ".axis: not 0, 1 or 2");
      node.axis = int(axis);
      node.split = r.number(r.key(tree[i], "split", where), where + ".split");
      const nlohmann::json& child = r.key(tree[i], "child", where);
      if (!child.is_array() || child.size() != 2) r.fail(where + ".child: not two node indices");
      for (size_t c = 0; c < 2; ++c)
        node.child[c] = int(std::min<uint64_t>(r.count(child[c], where + ".child"), 1u << 30));
    }
    index.tree.nodes.push_back(node);
  }
  std::vector<int> seen(index.tree.nodes.size(), 0);
  if (check_subtree(index.tree, 0, 0, seen, r) != n) r.fail("tree: its leaves are not the pieces");
  for (const PieceInfo& p : index.pieces) index.tree.boxes.push_back(p.box);
  // Every piece's store must be there: one missing is named now, before any rank starts rendering.
  for (int k = 0; k < n; ++k) {
    const std::string store = index.store_path(k);
    if (!std::filesystem::is_regular_file(store))
      r.fail("piece " + std::to_string(k) + "'s store " + store + " is missing");
  }
  return index;
}

void write_piece_index(const std::string& path, const PieceIndex& index) {
  nlohmann::ordered_json j;
  j["format"] = kFormat;
  j["version"] = kPieceIndexVersion;
  j["bounds"] = box_json(index.bounds);
  j["root"] = box_json(index.root);
  j["brick"] = index.brick;
  j["ghost_margin"] = index.ghost_margin;
  j["ghost_level"] = index.ghost_level;
  nlohmann::ordered_json fields = nlohmann::ordered_json::array();
  for (const BrickStoreField& f : index.fields)
    fields.push_back({{"name", f.name},
                      {"association", f.association == Association::Vertex ? "vertex" : "cell"},
                      {"min", f.min},
                      {"max", f.max}});
  j["fields"] = fields;
  nlohmann::ordered_json tree = nlohmann::ordered_json::array();
  for (const KdNode& n : index.tree.nodes) {
    if (n.axis < 0)
      tree.push_back({{"piece", n.part}});
    else
      tree.push_back({{"axis", n.axis}, {"split", n.split}, {"child", {n.child[0], n.child[1]}}});
  }
  j["tree"] = tree;
  nlohmann::ordered_json pieces = nlohmann::ordered_json::array();
  for (const PieceInfo& p : index.pieces)
    pieces.push_back({{"store", p.store},
                      {"box", box_json(p.box)},
                      {"cells", p.cells},
                      {"ghost_cells", p.ghost_cells},
                      {"store_bytes", p.store_bytes}});
  j["pieces"] = pieces;
  AtomicOutputFile out(path);
  out.write(j.dump(1) + "\n");
  out.commit();
}

KdTree group_tree(const KdTree& tree, int groups) {
  const int n = tree.parts();
  if (groups < 1 || (groups & (groups - 1)) != 0 || n % groups != 0)
    fail_in("kd-tree", std::to_string(groups) + " ranks cannot share " + std::to_string(n) +
                           " pieces: the rank count must be a power of two that divides the piece count");
  KdTree out;
  out.boxes.resize(size_t(groups));
  const Bounds all{{-kInf, -kInf, -kInf}, {kInf, kInf, kInf}};
  cut_tree(tree, 0, n / groups, all, out);
  return out;
}

}  // namespace ugvr
