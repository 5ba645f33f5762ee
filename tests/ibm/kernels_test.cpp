// The delta kernels on their own (no tree): normalisation, support, and the discrete
// moments kernels.hpp states, over a sweep of node offsets r in [0, 1).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "ibm/kernels.hpp"
#include "ibm/stencil.hpp"
#include "ibm_support.hpp"

namespace capsflow::ibm {
namespace {

// Raw (unnormalised) moments sum_k s_k^p phi(s_k) over the stencil of offset r.
template <Kernel K>
double raw_moment(double r, int p, bool squared = false) {
  constexpr int W = K::kSupport;
  double m = 0.0;
  for (int k = 0; k < W; ++k) {
    const double s = (k - W / 2 + 1) - r;
    const double w = K::weight(s);
    m += std::pow(s, p) * (squared ? w * w : w);
  }
  return m;
}

template <Kernel K>
void check_common() {
  constexpr int W = K::kSupport;
  EXPECT_EQ(K::weight(W / 2.0), 0.0);
  EXPECT_EQ(K::weight(-W / 2.0), 0.0);
  EXPECT_EQ(K::weight(W / 2.0 + 0.3), 0.0);
  for (int i = 0; i < 1000; ++i) {
    const double r = i / 1000.0;
    EXPECT_NEAR(raw_moment<K>(r, 0), 1.0, 2e-15) << K::kName << " r = " << r;
    // The normalised weights of a stencil sum to 1 and reproduce the raw ones.
    const auto a = axis_stencil<K>(0.37 + r * 0.125, 0.0, 0.125);
    double sum = 0.0;
    for (double w : a.w) sum += w;
    EXPECT_NEAR(sum, 1.0, 1e-15);
    EXPECT_GE(*std::min_element(a.w.begin(), a.w.end()), 0.0);
  }
}

TEST(Kernels, NormalisedWithCompactSupport) {
  check_common<CosineKernel>();
  check_common<HatKernel>();
  check_common<Peskin4Kernel>();
  // Peskin's two branches meet at |s| = 1; the weights are even.
  EXPECT_NEAR(Peskin4Kernel::weight(1.0 - 1e-12), Peskin4Kernel::weight(1.0 + 1e-12), 1e-11);
  for (double s : {0.1, 0.7, 1.3, 1.9}) {
    EXPECT_EQ(CosineKernel::weight(s), CosineKernel::weight(-s));
    EXPECT_EQ(Peskin4Kernel::weight(s), Peskin4Kernel::weight(-s));
    EXPECT_EQ(HatKernel::weight(s), HatKernel::weight(-s));
  }
  EXPECT_DOUBLE_EQ(CosineKernel::weight(0.0), 0.5);
  EXPECT_DOUBLE_EQ(HatKernel::weight(0.25), 0.75);
  EXPECT_DOUBLE_EQ(Peskin4Kernel::weight(0.0), 0.5);
}

TEST(Kernels, FirstMomentVanishesForHatAndPeskinNotForCosine) {
  double worst_cosine = 0.0;
  for (int i = 0; i < 1000; ++i) {
    const double r = i / 1000.0;
    EXPECT_NEAR(raw_moment<HatKernel>(r, 1), 0.0, 1e-15);
    EXPECT_NEAR(raw_moment<Peskin4Kernel>(r, 1), 0.0, 1e-15);
    const double m = raw_moment<CosineKernel>(r, 1);
    EXPECT_NEAR(m, test::cosine_first_moment(r), 1e-15);
    worst_cosine = std::max(worst_cosine, std::abs(m));
  }
  EXPECT_NEAR(raw_moment<CosineKernel>(0.0, 1), 0.0, 1e-15);
  EXPECT_NEAR(raw_moment<CosineKernel>(0.5, 1), 0.0, 1e-15);
  EXPECT_GT(worst_cosine, 0.02);
  EXPECT_LT(worst_cosine, 0.0211);
  std::printf("cosine kernel: max |first moment| = %.5f cells\n", worst_cosine);
}

TEST(Kernels, SumOfSquares) {
  for (int i = 0; i < 1000; ++i) {
    const double r = i / 1000.0;
    EXPECT_NEAR(raw_moment<CosineKernel>(r, 0, true), 0.375, 1e-15);
    EXPECT_NEAR(raw_moment<Peskin4Kernel>(r, 0, true), 0.375, 1e-15);
    EXPECT_NEAR(raw_moment<HatKernel>(r, 0, true), (1 - r) * (1 - r) + r * r, 1e-15);
  }
}

TEST(Kernels, CosineBatchedWeightsMatchTheFormula) {
  for (int i = 0; i < 1000; ++i) {
    const double r = i / 1000.0;
    double w[4];
    CosineKernel::stencil_weights(r, w);
    for (int k = 0; k < 4; ++k) EXPECT_NEAR(w[k], CosineKernel::weight(k - 1 - r), 2e-16) << r;
  }
}

TEST(Kernels, SmoothedCosineBatchedWeightsMatchTheFormula) {
  // The five faces i0 - 2 .. i0 + 2 around u = i0 - 1/2 + r (stencil.hpp's face_stencil).
  for (int i = 0; i <= 1000; ++i) {
    const double r = std::min(i / 1000.0, 1.0 - 1e-12);
    double w[5];
    CosineKernel::smoothed_stencil_weights(r, w);
    double sum = 0.0;
    for (int k = 0; k < 5; ++k) {
      EXPECT_NEAR(w[k], DivergenceFree<CosineKernel>::weight(k - 2 - (r - 0.5)), 4e-16) << r << " " << k;
      sum += w[k];
    }
    EXPECT_NEAR(sum, 1.0, 4e-16) << r;
  }
}

TEST(Kernels, RuntimeChoice) {
  EXPECT_EQ(support_of(KernelKind::cosine), 4);
  EXPECT_EQ(support_of(KernelKind::hat), 2);
  EXPECT_EQ(support_of(KernelKind::peskin4), 4);
  EXPECT_EQ(name_of(KernelKind::peskin4), "peskin4");
  EXPECT_EQ(with_kernel(KernelKind::hat, []<Kernel K>(K) { return K::weight(0.5); }), 0.5);
  EXPECT_EQ(band_cells(KernelKind::cosine, KernelKind::hat, 2), 4);
  EXPECT_EQ(band_cells(KernelKind::hat, KernelKind::hat, 0), 1);
  EXPECT_THROW((void)support_of(static_cast<KernelKind>(9)), std::invalid_argument);
}

}  // namespace
}  // namespace capsflow::ibm
