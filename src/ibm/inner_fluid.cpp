// Inner fluids (issue 29): the flow's density and viscosity from the insides of the capsules
// (CapsuleCoupling::inner_properties; the inside itself: indicator.hpp).
#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <stdexcept>

#include <fmt/format.h>

#include "ibm/capsule_coupling.hpp"
#include "ibm/indicator.hpp"
#include "parallel/sparse_exchange.hpp"
#include "tree/box_owners.hpp"

namespace capsflow::ibm {

void CapsuleCoupling::set_inner_fluid(int k, InnerFluid f) {
  if (k < 0 || k >= num_capsules()) throw std::out_of_range(fmt::format("ibm: no capsule {}", k));
  if (!(f.viscosity_ratio > 0.0) || !(f.density_ratio > 0.0) || !std::isfinite(f.viscosity_ratio) ||
      !std::isfinite(f.density_ratio))
    throw std::invalid_argument(fmt::format("ibm: capsule {}: inner viscosity ratio {} and density ratio {} must be finite and > 0",
                                            k, f.viscosity_ratio, f.density_ratio));
  inner_[static_cast<std::size_t>(k)] = f;
}

bool CapsuleCoupling::any_inner_fluid() const {
  return std::any_of(inner_.begin(), inner_.end(), [](const InnerFluid& f) { return !f.same(); });
}

void CapsuleCoupling::inner_properties(double rho_out, double mu_out, std::span<double> rho, std::span<double> mu) {
  const auto t0 = std::chrono::steady_clock::now();
  const tree::Tree<3>& t = ns_.tree();
  const int level = t.max_level();
  inside_.assign(static_cast<std::size_t>(t.num_cells()), 0.0);
  // mu holds 1/mu until the end: the insides add to the inverse viscosity.
  t.for_each_owned_leaf([&](tree::Index c) {
    rho[static_cast<std::size_t>(c)] = rho_out;
    mu[static_cast<std::size_t>(c)] = 1.0 / mu_out;
  });
  // The capsules this rank cuts, in id order, with their positions.
  std::vector<std::pair<int, Eigen::Matrix3Xd>> cut;
  if (!distributed()) {
    for (int k = 0; k < num_capsules(); ++k)
      if (!inner_[static_cast<std::size_t>(k)].same()) cut.emplace_back(k, capsule(k).x);
  } else {
    const parallel::Comm& comm = forest_->comm();
    const double h = t.cell_size(level);
    const auto& o = t.options();
    std::vector<std::vector<std::uint64_t>> send(static_cast<std::size_t>(comm.size()));
    std::vector<int> ranks;
    for (int k = 0; k < num_capsules(); ++k) {
      if (!owns(k) || inner_[static_cast<std::size_t>(k)].same()) continue;
      const Eigen::Matrix3Xd& x = capsule(k).x;
      // The max-level cells within the inside's reach (and one more) of the bounding box.
      const double reach = (0.5 * support_of(kInsideProfile) + 1.0) * h;
      tree::Coords<3> lo{}, hi{};
      for (int d = 0; d < 3; ++d) {
        lo[d] = static_cast<std::int32_t>(std::floor((x.row(d).minCoeff() - reach - o.origin[static_cast<std::size_t>(d)]) / h));
        hi[d] = static_cast<std::int32_t>(std::floor((x.row(d).maxCoeff() + reach - o.origin[static_cast<std::size_t>(d)]) / h));
      }
      ranks.clear();
      tree::box_owners<3>(forest_->partition(), o, level, lo, hi, ranks);
      for (const int q : ranks) {
        auto& w = send[static_cast<std::size_t>(q)];
        w.insert(w.end(), {static_cast<std::uint64_t>(k), static_cast<std::uint64_t>(x.cols())});
        for (Eigen::Index i = 0; i < x.size(); ++i) w.push_back(std::bit_cast<std::uint64_t>(x.data()[i]));
        if (q != comm.rank()) traffic_.words_sent += 2 + x.size();
      }
    }
    for (const auto& w : parallel::sparse_exchange(comm, send))
      for (const std::uint64_t* p = w.data(); p < w.data() + w.size();) {
        const auto k = static_cast<int>(*p++);
        const auto nodes = static_cast<Eigen::Index>(*p++);
        Eigen::Matrix3Xd x(3, nodes);
        for (Eigen::Index i = 0; i < x.size(); ++i) x.data()[i] = std::bit_cast<double>(*p++);
        cut.emplace_back(k, std::move(x));
      }
    std::sort(cut.begin(), cut.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  }
  for (const auto& [k, x] : cut) {
    const InnerFluid& f = inner_[static_cast<std::size_t>(k)];
    const auto inside = inside_cells(t, x, *surfaces_[static_cast<std::size_t>(k)], kInsideProfile, level);
    const double inverse_step = (1.0 / f.viscosity_ratio - 1.0) / mu_out;
    for (const InsideCell& c : inside) {
      rho[static_cast<std::size_t>(c.cell)] += (f.density_ratio - 1.0) * rho_out * c.value;
      mu[static_cast<std::size_t>(c.cell)] += inverse_step * c.value;
      inside_[static_cast<std::size_t>(c.cell)] += c.value;
    }
  }
  t.for_each_owned_leaf([&](tree::Index c) { mu[static_cast<std::size_t>(c)] = 1.0 / mu[static_cast<std::size_t>(c)]; });
  inside_seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace capsflow::ibm
