// The sparsity pattern of a solid's assembled Hessian (incremental_potential.h: hessian(),
// the direct Newton of 2-D): node pairs that share a particle's stencil, as a CSR pattern
// of the scalar Hessian with dim x dim blocks. Row (r, a) lists, for every neighbour slot
// s of node r (in increasing free number), the columns (c_s, 0 ... dim - 1). A pair of
// stencil entries (ei, ej) is coded by their offset difference in 5^dim codes, so a
// particle's block finds its place without a search. CG Newton (3-D) needs none of it.
#pragma once

#include <cassert>
#include <cstddef>
#include <vector>

#include "core/types.h"
#include "grid/grid.h"
#include "grid/kernels.h"

namespace iqmpm {

template <int dim>
class HessianPattern {
 public:
  static constexpr int kStencil = dim == 2 ? 9 : 27;       // 3^dim nodes of N2
  static constexpr int kNeighbours = dim == 2 ? 25 : 125;  // 5^dim node offsets within reach
  static constexpr int kCentreCode = dim == 2 ? 12 : 62;   // offset 0 in the 5^dim code

  bool empty() const { return row_start_.empty(); }
  const std::vector<int>& row_start() const { return row_start_; }
  const std::vector<int>& columns() const { return columns_; }
  // The 5^dim code of stencil entry ej's offset relative to entry ei's.
  int pair_code(int ei, int ej) const { return pair_code_[ei][ej]; }

  // From the free nodes (free number -> dense node of `layout`, and back) and the
  // particles' stencil entries (p * kStencil + e -> free number or -1).
  void build(const GridLayout<dim>& layout, const std::vector<int>& free_node, const std::vector<int>& free_number,
             const std::vector<int>& stencil_free) {
    const int particles = int(stencil_free.size()) / kStencil;
    // 5^dim code of offset(j) - offset(i) + 2 for two stencil entries.
    IVec<dim> offsets[kStencil];
    {
      int e = 0;
      for_each_offset<dim, 3>([&](const IVec<dim>& o) { offsets[e++] = o; });
    }
    for (int ei = 0; ei < kStencil; ++ei)
      for (int ej = 0; ej < kStencil; ++ej) {
        int code = 0;
        for (int a = 0; a < dim; ++a) code = code * 5 + (offsets[ej][a] - offsets[ei][a] + 2);
        pair_code_[ei][ej] = code;
      }

    const int count = int(free_node.size());
    slot_.assign(std::size_t(count) * kNeighbours, -1);
    for (int p = 0; p < particles; ++p)
      for (int ei = 0; ei < kStencil; ++ei) {
        const int ri = stencil_free[p * kStencil + ei];
        if (ri < 0) continue;
        for (int ej = 0; ej < kStencil; ++ej)
          if (stencil_free[p * kStencil + ej] >= 0) slot_[std::size_t(ri) * kNeighbours + pair_code_[ei][ej]] = 0;
      }
    // Every free node has mass, hence a particle, hence its own diagonal block.
    neighbour_count_.assign(count, 0);
    row_start_.assign(dim * count + 1, 0);
    columns_.clear();
    IVec<dim> delta_of_code[kNeighbours];
    {
      int code = 0;
      for_each_offset<dim, 5>([&](const IVec<dim>& o) { delta_of_code[code++] = o - IVec<dim>::Constant(2); });
    }
    for (int r = 0; r < count; ++r) {
      assert(slot_[std::size_t(r) * kNeighbours + kCentreCode] == 0);
      const IVec<dim> node = layout.multi_index(free_node[r]);
      std::vector<int> columns;
      // Codes increase with the dense index of the neighbour (first axis outermost), and
      // free numbers follow the dense order, so the columns come out sorted.
      for (int code = 0; code < kNeighbours; ++code) {
        int& s = slot_[std::size_t(r) * kNeighbours + code];
        if (s < 0) continue;
        s = neighbour_count_[r]++;
        columns.push_back(free_number[layout.index(node + delta_of_code[code])]);
      }
      for (int a = 0; a < dim; ++a) {
        for (int c : columns)
          for (int b = 0; b < dim; ++b) columns_.push_back(dim * c + b);
        row_start_[dim * r + a + 1] = int(columns_.size());
      }
    }
  }

  // Neighbour slot of node r at offset `code`.
  int slot(int r, int code) const {
    const int s = slot_[std::size_t(r) * kNeighbours + code];
    assert(s >= 0);
    return s;
  }
  // Value index of H_(r a),(c_s b).
  int entry(int r, int s, int a, int b) const {
    return row_start_[dim * r + a] + s * dim + b;
  }
  // values[H_(r a),(c_s b)] += block(a, b).
  void add_block(Real* values, int r, int s, const Mat<dim>& block) const {
    for (int a = 0; a < dim; ++a)
      for (int b = 0; b < dim; ++b) values[entry(r, s, a, b)] += block(a, b);
  }

 private:
  int pair_code_[kStencil][kStencil];
  std::vector<int> slot_;  // r * kNeighbours + code -> neighbour slot or -1
  std::vector<int> neighbour_count_;
  std::vector<int> row_start_;
  std::vector<int> columns_;
};

}  // namespace iqmpm
