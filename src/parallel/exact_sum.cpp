#include "parallel/exact_sum.hpp"

#include <bit>
#include <cmath>
#include <limits>

namespace capsflow::parallel {

namespace {

// 128-bit integers (GCC and Clang): a shifted 53-bit mantissa and the rounding window.
__extension__ typedef unsigned __int128 U128;

constexpr std::int64_t kRadix = std::int64_t{1} << 32;
constexpr std::int64_t kMask = kRadix - 1;
constexpr int kBias = 1074;  // bit 0 of digit 0 weighs 2^-kBias
// Each addition puts less than 2^32 into a digit; 2^30 of them fit in an int64 with room.
constexpr std::int64_t kNormalizeEvery = std::int64_t{1} << 30;

}  // namespace

void ExactSum::add(double x) {
  if (!std::isfinite(x)) {
    if (std::isnan(x)) ++nan_;
    else if (x > 0) ++pos_inf_;
    else ++neg_inf_;
    return;
  }
  if (x == 0.0) return;
  int e = 0;
  const double f = std::frexp(std::fabs(x), &e);            // |x| = f 2^e, f in [0.5, 1)
  auto m = static_cast<std::uint64_t>(std::ldexp(f, 53));  // exact: 53 significant bits
  int bit = e - 53 + kBias;                                 // |x| = m 2^(bit - kBias)
  if (bit < 0) {  // a subnormal: its low bits are zeros, the shift is exact
    m >>= -bit;
    bit = 0;
  }
  const int d = bit / 32;
  const U128 v = static_cast<U128>(m) << (bit % 32);  // < 2^85
  const std::int64_t sign = x < 0 ? -1 : 1;
  digit_[d] += sign * static_cast<std::int64_t>(static_cast<std::uint64_t>(v) & kMask);
  digit_[d + 1] += sign * static_cast<std::int64_t>(static_cast<std::uint64_t>(v >> 32) & kMask);
  digit_[d + 2] += sign * static_cast<std::int64_t>(static_cast<std::uint64_t>(v >> 64));
  if (++pending_ >= kNormalizeEvery) normalize();
}

void ExactSum::add(const ExactSum& other) {
  ExactSum o = other;
  o.normalize();
  normalize();
  for (int i = 0; i < kDigits; ++i) digit_[i] += o.digit_[i];
  nan_ += o.nan_;
  pos_inf_ += o.pos_inf_;
  neg_inf_ += o.neg_inf_;
  pending_ = 1;
}

void ExactSum::normalize() {
  for (int i = 0; i + 1 < kDigits; ++i) {
    const std::int64_t carry = digit_[i] >> 32;  // floor division (C++20: arithmetic shift)
    digit_[i] -= carry * kRadix;
    digit_[i + 1] += carry;
  }
  pending_ = 0;
}

double ExactSum::value() const {
  if (nan_ > 0 || (pos_inf_ > 0 && neg_inf_ > 0)) return std::numeric_limits<double>::quiet_NaN();
  if (pos_inf_ > 0) return std::numeric_limits<double>::infinity();
  if (neg_inf_ > 0) return -std::numeric_limits<double>::infinity();
  ExactSum s = *this;
  s.normalize();
  // Below the top digit every digit is non-negative, so the sign is the top digit's.
  const bool negative = s.digit_[kDigits - 1] < 0;
  if (negative) {
    for (auto& v : s.digit_) v = -v;
    s.normalize();
  }
  int top = kDigits - 1;
  while (top >= 0 && s.digit_[top] == 0) --top;
  if (top < 0) return 0.0;
  // The three leading digits (at least 65 significant bits), the rest as a sticky bit.
  const int low = top >= 2 ? top - 2 : 0;
  U128 window = 0;
  for (int i = top; i >= low; --i) window = (window << 32) | static_cast<std::uint64_t>(s.digit_[i]);
  bool sticky = false;
  for (int i = 0; i < low; ++i) sticky = sticky || s.digit_[i] != 0;
  const auto hi = static_cast<std::uint64_t>(window >> 64), lo = static_cast<std::uint64_t>(window);
  const int length = hi != 0 ? 128 - std::countl_zero(hi) : 64 - std::countl_zero(lo);
  int exponent = 32 * low - kBias;
  std::uint64_t mantissa = 0;
  if (length <= 53) {
    mantissa = lo;  // exact (sticky is false: the window holds every digit when it is this short)
  } else {
    const int shift = length - 53;
    mantissa = static_cast<std::uint64_t>(window >> shift);
    const U128 rest = window & ((static_cast<U128>(1) << shift) - 1);
    const U128 half = static_cast<U128>(1) << (shift - 1);
    if (rest > half || (rest == half && (sticky || (mantissa & 1u) != 0))) ++mantissa;
    exponent += shift;
  }
  const double magnitude = std::ldexp(static_cast<double>(mantissa), exponent);
  return negative ? -magnitude : magnitude;
}

std::array<std::int64_t, ExactSum::kWords> ExactSum::words() const {
  ExactSum s = *this;
  s.normalize();
  std::array<std::int64_t, kWords> w{};
  for (int i = 0; i < kDigits; ++i) w[i] = s.digit_[i];
  w[kDigits] = nan_;
  w[kDigits + 1] = pos_inf_;
  w[kDigits + 2] = neg_inf_;
  return w;
}

ExactSum ExactSum::from_words(const std::array<std::int64_t, kWords>& w) {
  ExactSum s;
  for (int i = 0; i < kDigits; ++i) s.digit_[i] = w[i];
  s.nan_ = w[kDigits];
  s.pos_inf_ = w[kDigits + 1];
  s.neg_inf_ = w[kDigits + 2];
  s.normalize();
  return s;
}

}  // namespace capsflow::parallel
