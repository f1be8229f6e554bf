// The incremental potential of the solid's implicit step (method.md §3 step 2), over the
// velocities of the active quadratic nodes (N2, mass > 0) that are not clamped:
//
//   E(v) = sum_i m_i/2 |v_i - v_i^n|^2 + (dt / tau) sum_p V0_p Psi(F_p(v)),
//   F_p(v) = F_p^n + tau sum_i (v_i + u_i) b_ip^T,   b_ip = F_p^nT grad w_ip,
//
// with its gradient  g_i = m_i (v_i - v_i^n) + dt sum_p V0_p P(F_p) b_ip
// and its Hessian    H = M + dt tau sum_p V0_p (dF_p/dv)^T dP/dF (dF_p/dv),
// dP/dF optionally projected to PSD per particle (psd_projection.h), so that H is SPD.
// Gravity is already in v^n (P2G, §3 step 1). The rule (SolidTimeIntegration) sets tau and u:
//   implicit Euler: tau = dt, u = 0: the force at the end of the step, F_p(v) = F_p^{n+1};
//   midpoint: tau = dt / 4, u = the nodes' velocity at the step's start without this step's
//   gravity (SolidNodes::start_velocity): the step moves the material with the mean velocity
//   (u + v) / 2, so F_p^{n+1} = F_p^n + dt/2 sum (v_i + u_i) b^T and F_p(v) = (F_p^n +
//   F_p^{n+1}) / 2, the midpoint configuration (method.md#solid-time-integration). The
//   stationarity m (v - v^n) = -dt sum_p V0 P(F_mid) b is the implicit midpoint rule, which
//   keeps the energy of a vibrating solid where implicit Euler removes (omega dt)^2 of it a
//   step; its Hessian carries dt^2 / 4 K, the trapezoidal rule's effective stiffness.
//
// Unknowns: node r of the free (active, not clamped) nodes, numbered in the order of
// Grid::nodes(), owns entries r*dim .. r*dim+dim-1. A clamped node (Dirichlet) keeps its
// prescribed velocity: it enters F_p as a constant and is not an unknown; its kinetic
// term is then constant and left out of E. The Hessian's sparsity pattern (the node pairs
// that share a particle) is built once per step; every evaluation fills the same pattern.
// A wall-held component (SolidNodes::fixed_axes) stays an unknown, but starts at zero and
// has a zero gradient entry and an identity-times-mass Hessian row and column, so Newton
// never moves it: the Dirichlet condition by projection, without renumbering the blocks.
#pragma once

#include <Eigen/Core>
#include <Eigen/SparseCore>

#include <cassert>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "core/types.h"
#include "grid/grid.h"
#include "grid/kernels.h"
#include "particles/particles.h"
#include "solid/hessian_pattern.h"
#include "solid/time_integration.h"

namespace iqmpm {

// The solid's nodal state entering the Newton step, dense over Grid::nodes().
template <int dim>
struct SolidNodes {
  std::vector<Real> mass;                  // m_i from solid P2G
  std::vector<Vec<dim>> velocity;          // v_i^n = momentum / mass, gravity included
  std::vector<std::uint8_t> clamped;       // 1 = Dirichlet node; empty: no node clamped
  std::vector<Vec<dim>> clamped_velocity;  // prescribed velocity; empty: zero
  // Bit a set: component a of the node is held at zero (a free-slip wall normal, method.md
  // §1); the other components stay free. Empty: no such node.
  std::vector<std::uint8_t> fixed_axes;
  // The midpoint rule's u: v at the step's start, before this step's gravity, with the
  // wall-held components at zero (the wall holds them over the whole step); a clamped
  // node's is its velocity at the start. Unused by implicit Euler; empty: zero.
  std::vector<Vec<dim>> start_velocity;
};

template <int dim, class Material>
class SolidIncrementalPotential {
 public:
  using Vector = Eigen::Matrix<Real, Eigen::Dynamic, 1>;
  using SparseMatrix = Eigen::SparseMatrix<Real, Eigen::RowMajor, int>;

  // Every particle uses `material`.
  SolidIncrementalPotential(const Grid<dim>& grid, const Particles<dim>& particles,
                            const Material& material, const SolidNodes<dim>& nodes, Real dt,
                            SolidTimeIntegration rule = SolidTimeIntegration::implicit_euler)
      : SolidIncrementalPotential(grid, particles, std::vector<Material>{material}, {}, nodes,
                                  dt, rule) {}

  // Particle p uses materials[material_of_particle[p]] (e.g. Particles::body when several
  // solids of one model differ in parameters); an empty index vector means materials[0].
  SolidIncrementalPotential(const Grid<dim>& grid, const Particles<dim>& particles,
                            std::vector<Material> materials, std::vector<int> material_of_particle,
                            const SolidNodes<dim>& nodes, Real dt,
                            SolidTimeIntegration rule = SolidTimeIntegration::implicit_euler)
      : layout_(grid.nodes()),
        dt_(dt),
        rule_(rule),
        tau_(rule == SolidTimeIntegration::midpoint ? Real(0.25) * dt : dt),
        energy_weight_(rule == SolidTimeIntegration::midpoint ? Real(4) : Real(1)),
        dx_(grid.dx),
        materials_(std::move(materials)),
        material_of_particle_(std::move(material_of_particle)) {
    assert(!materials_.empty());
    assert(int(nodes.mass.size()) == layout_.size() && int(nodes.velocity.size()) == layout_.size());
    assert(particles.deformation_gradient.size() == particles.size());
    assert(material_of_particle_.empty() || material_of_particle_.size() == particles.size());
    number_free_nodes(nodes);
    gather_particles(grid, particles, nodes);
  }

  int unknowns() const { return dim * int(free_node_.size()); }
  int particle_count() const { return int(volume_.size()); }
  const GridLayout<dim>& node_layout() const { return layout_; }
  // Dense node index of free node r, and the free number of a dense node (-1: not free).
  int dense_node(int r) const { return free_node_[r]; }
  int free_number(int dense) const { return free_number_[dense]; }
  const std::vector<int>& free_numbers() const { return free_number_; }

  // v^n on the free nodes, wall-held components at zero: the usual starting guess.
  Vector initial_velocity() const {
    Vector v = velocity_n_;
    for (int k : fixed_entries_) v[k] = 0;
    return v;
  }
  // m_i repeated per component: the kinetic part of the Hessian.
  const Vector& mass_diagonal() const { return mass_; }

  // A gradient magnitude for absolute tolerances: the momentum of all nodes moving at
  // max |v^n| + dx/dt (dx/dt keeps it positive for a body at rest).
  Real gradient_scale() const {
    Real speed = 0;
    for (int r = 0; r < int(free_node_.size()); ++r)
      speed = std::max(speed, velocity_n_.template segment<dim>(dim * r).norm());
    return mass_.norm() * (speed + dx_ / dt_);
  }

  Mat<dim> deformation_gradient(int p, const Vector& v) const {
    Mat<dim> F = F_constant_[p];
    for (int e = 0; e < kStencil; ++e) {
      const int r = stencil_free_[p * kStencil + e];
      if (r >= 0) F.noalias() += tau_ * v.template segment<dim>(dim * r) * b_[p * kStencil + e].transpose();
    }
    return F;
  }

  Real kinetic_energy(const Vector& v) const {
    return Real(0.5) * (mass_.array() * (v - velocity_n_).array().square()).sum();
  }

  // (dt / tau) sum_p V0_p Psi(F_p(v)); +infinity when some F_p is non-finite or outside the
  // material's domain (neo-Hookean J <= 0).
  // The SVDs it computes are kept for gradient() and particle_stiffness() at the same v
  // (the minimiser evaluates them at the accepted trial): one SVD per particle and Newton
  // iteration instead of three (issue 21; bit-identical results).
  Real elastic_energy(const Vector& v) const {
    const int n = particle_count();
    svd_.resize(n);
    has_svd_.assign(n, 0);
    Real sum = 0;
#pragma omp parallel for schedule(static) reduction(+ : sum)
    for (int p = 0; p < n; ++p) {
      const Mat<dim> F = deformation_gradient(p, v);
      if (!F.allFinite()) {
        sum += std::numeric_limits<Real>::infinity();
      } else if (material(p).energy_needs_svd()) {
        svd_[p] = rotation_variant_svd<dim>(F);
        has_svd_[p] = 1;
        sum += volume_[p] * material(p).energy_density(svd_[p]);
      } else {
        sum += volume_[p] * material(p).energy_density(F);
      }
    }
    svd_velocity_ = v;
    sum *= energy_weight_;
    return std::isfinite(sum) ? sum : std::numeric_limits<Real>::infinity();
  }

  Real energy(const Vector& v) const {
    const Real value = kinetic_energy(v) + elastic_energy(v);
    return std::isfinite(value) ? value : std::numeric_limits<Real>::infinity();
  }

  // Requires energy(v) finite.
  Vector gradient(const Vector& v) const {
    const int n = particle_count();
    std::vector<Mat<dim>> stress(n);  // dt V0_p P(F_p)
    const bool kept = svd_kept_for(v);
#pragma omp parallel for schedule(static)
    for (int p = 0; p < n; ++p)
      stress[p] = dt_ * volume_[p] *
                  (kept && has_svd_[p] ? material(p).first_piola(svd_[p]) : material(p).first_piola(deformation_gradient(p, v)));
    Vector g = mass_.cwiseProduct(v - velocity_n_);
    scatter_to_nodes(stress, g);
    for (int k : fixed_entries_) g[k] = 0;
    return g;
  }

  // Requires energy(v) finite. Symmetric to the last bit; SPD when project_to_psd.
  // dt tau V0_p dP/dF(F_p(v)) per particle: the elastic Hessian's building block.
  std::vector<TensorMat<dim>> particle_stiffness(const Vector& v, bool project_to_psd) const {
    const int n = particle_count();
    std::vector<TensorMat<dim>> stiffness(n);
    const bool kept = svd_kept_for(v);
#pragma omp parallel for schedule(static)
    for (int p = 0; p < n; ++p)
      stiffness[p] = dt_ * tau_ * volume_[p] *
                     (kept && has_svd_[p] ? material(p).first_piola_derivative(svd_[p], project_to_psd)
                                          : material(p).first_piola_derivative(deformation_gradient(p, v), project_to_psd));
    return stiffness;
  }

  SparseMatrix hessian(const Vector& v, bool project_to_psd) const {
    // Only an assembled Hessian needs the pattern; built on first use.
    if (pattern_.empty()) pattern_.build(layout_, free_node_, free_number_, stencil_free_);
    const int n = particle_count();
    const std::vector<TensorMat<dim>> stiffness = particle_stiffness(v, project_to_psd);

    SparseMatrix H(unknowns(), unknowns());
    const std::vector<int>& row_start = pattern_.row_start();
    const std::vector<int>& columns = pattern_.columns();
    H.resizeNonZeros(int(columns.size()));
    std::copy(row_start.begin(), row_start.end(), H.outerIndexPtr());
    std::copy(columns.begin(), columns.end(), H.innerIndexPtr());
    Real* values = H.valuePtr();
    std::fill(values, values + columns.size(), Real(0));

    for (int r = 0; r < int(free_node_.size()); ++r) {
      const int own = pattern_.slot(r, HessianPattern<dim>::kCentreCode);  // node r with itself
      for (int a = 0; a < dim; ++a) values[pattern_.entry(r, own, a, a)] += mass_[dim * r + a];
    }

    // Block (i, j) of particle p: H_(i a),(j b) = sum_cd A_(c dim + a),(d dim + b) b_i[c] b_j[d],
    // A = dt tau V0 dP/dF, since dF/dv_(i a) = tau e_a b_i^T has vec entries tau b_i[c] at
    // c dim + a (and the energy's weight is dt / tau).
    using RowBlock = Eigen::Matrix<Real, dim, dim * dim>;
    for (int p = 0; p < n; ++p) {
      const TensorMat<dim>& A = stiffness[p];
      for (int ei = 0; ei < kStencil; ++ei) {
        const int ri = stencil_free_[p * kStencil + ei];
        if (ri < 0) continue;
        const Vec<dim>& bi = b_[p * kStencil + ei];
        RowBlock X = RowBlock::Zero();  // (dF/dv_i)^T A
        for (int c = 0; c < dim; ++c) X.noalias() += bi[c] * A.template middleRows<dim>(c * dim);
        for (int ej = ei; ej < kStencil; ++ej) {
          const int rj = stencil_free_[p * kStencil + ej];
          if (rj < 0) continue;
          const Vec<dim>& bj = b_[p * kStencil + ej];
          Mat<dim> block = Mat<dim>::Zero();
          for (int d = 0; d < dim; ++d) block.noalias() += bj[d] * X.template middleCols<dim>(d * dim);
          if (ej == ei) {
            const Mat<dim> symmetric = Real(0.5) * (block + block.transpose());
            pattern_.add_block(values, ri, pattern_.slot(ri, pattern_.pair_code(ei, ej)), symmetric);
          } else {
            pattern_.add_block(values, ri, pattern_.slot(ri, pattern_.pair_code(ei, ej)), block);
            pattern_.add_block(values, rj, pattern_.slot(rj, pattern_.pair_code(ej, ei)), block.transpose());
          }
        }
      }
    }
    if (!fixed_entries_.empty())
      for (int row = 0; row < unknowns(); ++row)
        for (int k = row_start[row]; k < row_start[row + 1]; ++k) {
          const int column = columns[k];
          if (fixed_[row] || fixed_[column]) values[k] = row == column ? mass_[row] : 0;
        }
    return H;
  }

  // The Hessian at v without assembling it, for CG (projected_newton.h): the particles'
  // stiffness dt tau V0_p dP/dF(F_p) and the Hessian's diagonal. A product then costs a
  // gather, a dim^2 x dim^2 product and a scatter per particle, where the assembly above
  // forms (3^dim)^2 / 2 blocks per particle (in 3-D, 365 of them, each 3 x 3).
  struct Linearization {
    std::vector<TensorMat<dim>> stiffness;
    Vector diagonal;
  };

  Linearization linearize(const Vector& v, bool project_to_psd) const {
    Linearization out;
    out.stiffness = particle_stiffness(v, project_to_psd);
    out.diagonal = mass_;
    // H_(i a),(i a) = m_i + sum_p sum_cd A_(c dim + a),(d dim + a) b_i[c] b_i[d], node by node
    // over its particles in increasing p (scatter_to_nodes' order: bits independent of threads).
    const int free_count = int(free_node_.size());
#pragma omp parallel for schedule(static)
    for (int r = 0; r < free_count; ++r)
      for (int k = node_entry_start_[r]; k < node_entry_start_[r + 1]; ++k) {
        const TensorMat<dim>& A = out.stiffness[node_entries_[k] / kStencil];
        const Vec<dim>& b = b_[node_entries_[k]];
        for (int a = 0; a < dim; ++a)
          for (int c = 0; c < dim; ++c)
            for (int d = 0; d < dim; ++d) out.diagonal[dim * r + a] += A(c * dim + a, d * dim + a) * b[c] * b[d];
      }
    for (int k : fixed_entries_) out.diagonal[k] = mass_[k];
    return out;
  }

  // H x = M x + P K P x (P: zero on the wall-held entries, whose rows and columns are the
  // mass alone, as in hessian()). Per particle: dF = sum_j x_j b_j^T, dP = A : dF,
  // (K x)_i += dP b_i (A acts on column-major vec(dF), the layout of hessian()).
  Vector hessian_product(const Linearization& linear, const Vector& x) const {
    Vector projected = x;
    for (int k : fixed_entries_) projected[k] = 0;
    const int n = particle_count();
    std::vector<Mat<dim>> stress_change(n);
#pragma omp parallel for schedule(static)
    for (int p = 0; p < n; ++p) {
      Mat<dim> dF = Mat<dim>::Zero();
      for (int e = 0; e < kStencil; ++e) {
        const int r = stencil_free_[p * kStencil + e];
        if (r >= 0) dF.noalias() += projected.template segment<dim>(dim * r) * b_[p * kStencil + e].transpose();
      }
      const Eigen::Matrix<Real, dim * dim, 1> dP =
          linear.stiffness[p] * Eigen::Map<const Eigen::Matrix<Real, dim * dim, 1>>(dF.data());
      stress_change[p] = Eigen::Map<const Mat<dim>>(dP.data());
    }
    Vector y = Vector::Zero(x.size());
    scatter_to_nodes(stress_change, y);
    for (int k : fixed_entries_) y[k] = 0;
    return y + mass_.cwiseProduct(x);
  }

  // Writes the nodal velocities, dense over Grid::nodes(): v on free nodes, the prescribed
  // velocity on clamped active nodes, v^n (unchanged) on inactive nodes.
  void scatter(const Vector& v, std::vector<Vec<dim>>& node_velocity) const {
    node_velocity = dense_velocity_;
    for (int r = 0; r < int(free_node_.size()); ++r)
      node_velocity[free_node_[r]] = v.template segment<dim>(dim * r);
  }

 private:
  static constexpr int kStencil = HessianPattern<dim>::kStencil;  // 3^dim nodes of N2

  // The SVDs of the last energy evaluation, valid for that velocity only.
  bool svd_kept_for(const Vector& v) const { return svd_velocity_.size() == v.size() && svd_velocity_ == v; }

  const Material& material(int p) const {
    return material_of_particle_.empty() ? materials_[0] : materials_[material_of_particle_[p]];
  }

  void number_free_nodes(const SolidNodes<dim>& nodes) {
    const int size = layout_.size();
    const bool any_clamped = !nodes.clamped.empty();
    assert(!any_clamped || int(nodes.clamped.size()) == size);
    assert(nodes.clamped_velocity.empty() || int(nodes.clamped_velocity.size()) == size);
    dense_velocity_ = nodes.velocity;
    free_number_.assign(size, -1);
    clamped_value_.assign(size, Vec<dim>::Zero());
    for (int k = 0; k < size; ++k) {
      if (!(nodes.mass[k] > 0)) continue;
      if (any_clamped && nodes.clamped[k]) {
        if (!nodes.clamped_velocity.empty()) clamped_value_[k] = nodes.clamped_velocity[k];
        dense_velocity_[k] = clamped_value_[k];
        continue;
      }
      free_number_[k] = int(free_node_.size());
      free_node_.push_back(k);
    }
    const int count = int(free_node_.size());
    mass_.resize(dim * count);
    velocity_n_.resize(dim * count);
    fixed_.assign(dim * count, 0);
    for (int r = 0; r < count; ++r) {
      mass_.template segment<dim>(dim * r).setConstant(nodes.mass[free_node_[r]]);
      velocity_n_.template segment<dim>(dim * r) = nodes.velocity[free_node_[r]];
      if (nodes.fixed_axes.empty()) continue;
      for (int a = 0; a < dim; ++a)
        if (nodes.fixed_axes[free_node_[r]] & (1u << a)) {
          fixed_[dim * r + a] = 1;
          fixed_entries_.push_back(dim * r + a);
        }
    }
  }

  // Per particle: V0, b_ip for its 3^dim nodes, their free numbers, and the constant part
  // of F_p(v): F^n, plus the clamped nodes' terms (dt v_c; midpoint: tau (v_c + u_c)), plus
  // tau u_i on the free nodes (midpoint).
  void gather_particles(const Grid<dim>& grid, const Particles<dim>& particles, const SolidNodes<dim>& nodes) {
    const int n = int(particles.size());
    volume_.resize(n);
    F_constant_.resize(n);
    b_.resize(std::size_t(n) * kStencil);
    stencil_free_.resize(std::size_t(n) * kStencil);
    const bool midpoint = rule_ == SolidTimeIntegration::midpoint && !nodes.start_velocity.empty();
    assert(nodes.start_velocity.empty() || int(nodes.start_velocity.size()) == layout_.size());
#pragma omp parallel for schedule(static)  // each particle writes its own entries
    for (int p = 0; p < n; ++p) {
      const Mat<dim>& Fn = particles.deformation_gradient[p];
      const auto stencil = quadratic_stencil<dim>(grid.to_cells(particles.position[p]), grid.dx);
      volume_[p] = particles.initial_volume[p];
      F_constant_[p] = Fn;
      int e = 0;
      for_each_offset<dim, 3>([&](const IVec<dim>& offset) {
        const IVec<dim> node = stencil.base + offset;
        assert(layout_.contains(node) && "solid particle outside the padded node layout");
        const int k = layout_.index(node);
        const Vec<dim> b = Fn.transpose() * stencil.gradient(offset);
        b_[p * kStencil + e] = b;
        stencil_free_[p * kStencil + e] = free_number_[k];
        // An inactive node (zero mass) of a particle's stencil has zero weight and gradient.
        if (free_number_[k] < 0 && nodes.mass[k] > 0) {
          if (midpoint) F_constant_[p].noalias() += tau_ * (clamped_value_[k] + nodes.start_velocity[k]) * b.transpose();
          else F_constant_[p].noalias() += dt_ * clamped_value_[k] * b.transpose();
        }
        if (free_number_[k] >= 0 && midpoint) F_constant_[p].noalias() += tau_ * nodes.start_velocity[k] * b.transpose();
        ++e;
      });
    }
    // Each free node's stencil entries p * kStencil + e, in increasing p.
    const int free_count = int(free_node_.size());
    node_entry_start_.assign(free_count + 1, 0);
    for (int r : stencil_free_)
      if (r >= 0) ++node_entry_start_[r + 1];
    for (int r = 0; r < free_count; ++r) node_entry_start_[r + 1] += node_entry_start_[r];
    node_entries_.resize(node_entry_start_[free_count]);
    std::vector<int> next(node_entry_start_.begin(), node_entry_start_.end() - 1);
    for (int k = 0; k < int(stencil_free_.size()); ++k)
      if (stencil_free_[k] >= 0) node_entries_[next[stencil_free_[k]]++] = k;
  }

  // out_r += sum over node r's stencil entries (in increasing p) of per_particle[p] b_(p, e):
  // the transpose of the particle gather, run on the threads node by node. Each node adds
  // in the order a serial loop over the particles would: the same bits for any thread count.
  void scatter_to_nodes(const std::vector<Mat<dim>>& per_particle, Vector& out) const {
    const int free_count = int(free_node_.size());
#pragma omp parallel for schedule(static)
    for (int r = 0; r < free_count; ++r) {
      Vec<dim> sum = out.template segment<dim>(dim * r);
      for (int k = node_entry_start_[r]; k < node_entry_start_[r + 1]; ++k)
        sum += per_particle[node_entries_[k] / kStencil] * b_[node_entries_[k]];
      out.template segment<dim>(dim * r) = sum;
    }
  }

  GridLayout<dim> layout_;
  Real dt_;
  SolidTimeIntegration rule_;
  Real tau_;            // F_p(v)'s velocity factor: dt (implicit Euler) or dt / 4 (midpoint)
  Real energy_weight_;  // dt / tau: the gradient's factor stays dt
  Real dx_;
  std::vector<Material> materials_;
  mutable std::vector<RotationVariantSvd<dim>> svd_;  // elastic_energy()'s, per particle
  mutable std::vector<std::uint8_t> has_svd_;
  mutable Vector svd_velocity_;
  std::vector<int> material_of_particle_;

  std::vector<int> free_node_;    // free number -> dense node
  std::vector<int> free_number_;  // dense node -> free number or -1
  std::vector<Vec<dim>> clamped_value_;   // dense; prescribed velocity of clamped nodes
  std::vector<Vec<dim>> dense_velocity_;  // dense; v^n, clamped nodes set to their value
  Vector mass_;        // per unknown
  Vector velocity_n_;  // per unknown
  std::vector<char> fixed_;         // per unknown: held at zero by a wall
  std::vector<int> fixed_entries_;  // the unknowns with fixed_ set

  std::vector<Real> volume_;
  std::vector<Mat<dim>> F_constant_;
  std::vector<Vec<dim>> b_;          // p * kStencil + e
  std::vector<int> stencil_free_;    // p * kStencil + e -> free number or -1
  std::vector<int> node_entry_start_, node_entries_;  // free node -> its entries p * kStencil + e

  // The assembled Hessian's pattern, built by the first hessian() call (CG Newton needs none).
  mutable HessianPattern<dim> pattern_;
};

}  // namespace iqmpm
