#pragma once
// Snapshots of the tree's leaves as a VTK unstructured grid (.vtu, for ParaView).
//
// Each leaf becomes one VTK_QUAD (2D) or VTK_HEXAHEDRON (3D) with its own 4 or 8 corner
// points: corners are not shared between cells. Sharing would need a hash of corner
// coordinates per snapshot and saves nothing ParaView needs (the data are cell data, and
// hanging nodes make the mesh non-conforming anyway); zlib compresses the repetition.
// Corner order is VTK's: (lo,lo), (hi,lo), (hi,hi), (lo,hi) in the x-y plane, then, in 3D,
// the same four at z hi. Points are Float64 (exact corner coordinates); 2D points have
// z = 0. Cells follow Tree::owned_leaves() (Tree::leaves() on one rank).
//
// Cell data: `level` (Int32) and every field given, as Float64.
#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include "tree/tree.hpp"

namespace capsflow::io {

// A field over the tree's cells: one span per component, each of size tree.num_cells()
// (as Tree::values gives them). One component is a scalar; 2 or 3 make a vector, written
// with 3 components (a 2D vector gets z = 0, so ParaView's glyphs and stream tracers work).
struct CellField {
  std::string name;
  std::vector<std::span<const double>> components;
};

// The leaves this rank owns (every leaf on one rank). Throws std::invalid_argument for a
// field with 0 or more than 3 components, a span of the wrong size, or a field named
// "level"; std::runtime_error if the file cannot be written.
template <int D>
void write_tree_vtu(const std::filesystem::path& path, const tree::Tree<D>& tree,
                    std::span<const CellField> fields);

// On N ranks: this rank's owned leaves as piece `piece` of `pieces` of the .pvtu at `path`
// (the piece in the folder <stem>/ next to it; piece 0 writes the .pvtu, which ParaView and
// VTK's XML reader open as one grid). Every rank calls it, with the same fields. Throws as
// write_tree_vtu.
template <int D>
void write_tree_pvtu_piece(const std::filesystem::path& path, const tree::Tree<D>& tree,
                           std::span<const CellField> fields, int piece, int pieces);

extern template void write_tree_vtu<2>(const std::filesystem::path&, const tree::Tree<2>&,
                                       std::span<const CellField>);
extern template void write_tree_vtu<3>(const std::filesystem::path&, const tree::Tree<3>&,
                                       std::span<const CellField>);
extern template void write_tree_pvtu_piece<2>(const std::filesystem::path&, const tree::Tree<2>&,
                                              std::span<const CellField>, int, int);
extern template void write_tree_pvtu_piece<3>(const std::filesystem::path&, const tree::Tree<3>&,
                                              std::span<const CellField>, int, int);

}  // namespace capsflow::io
