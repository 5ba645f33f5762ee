#pragma once
// An exact sum of doubles, independent of the order of the terms (so of the thread count,
// the rank count and the partition): every term is added without rounding into a long
// fixed-point accumulator (radix-2^32 digits held in 64-bit integers, spanning every
// binary64 exponent, subnormals included) and the total is rounded once, to nearest, when
// read. This is the "long accumulator" of Kulisch; ReproBLAS and Demmel & Nguyen's
// reproducible summation trade exactness for speed, which a few reductions per step do not
// need. Cost: a few integer additions per term, about 3 ns here.
//
// Non-finite terms are counted apart: any NaN, or +inf and -inf together, make the total
// NaN; otherwise an infinite term makes it that infinity.
#include <array>
#include <cstdint>
#include <span>

namespace capsflow::parallel {

class ExactSum {
 public:
  // Digits: bit 0 of digit 0 weighs 2^-1074 (the smallest subnormal); 68 digits reach past
  // 2^1024, so no finite term, nor any sum of fewer than 2^31 of them, overflows.
  static constexpr int kDigits = 68;
  // The wire format for a reduction: the digits, then the counts of NaN, +inf and -inf.
  static constexpr int kWords = kDigits + 3;

  ExactSum() = default;
  void add(double x);
  void add(std::span<const double> xs) {
    for (const double x : xs) add(x);
  }
  void add(const ExactSum& other);
  // The total rounded to nearest (ties to even), or NaN / inf as above.
  [[nodiscard]] double value() const;

  // The state as words whose element-wise integer sum over several accumulators is the
  // state of their sum (what MPI_Allreduce with MPI_SUM computes), and back.
  [[nodiscard]] std::array<std::int64_t, kWords> words() const;
  static ExactSum from_words(const std::array<std::int64_t, kWords>& w);

 private:
  // Carries so that digits 0..kDigits-2 lie in [0, 2^32); the top digit holds the sign.
  void normalize();

  std::array<std::int64_t, kDigits> digit_{};
  std::int64_t nan_ = 0, pos_inf_ = 0, neg_inf_ = 0;
  std::int64_t pending_ = 0;  // additions since the last normalize
};

}  // namespace capsflow::parallel
