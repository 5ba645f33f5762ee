#pragma once
// Spellings of the case-file enums, shared by the parser and the writer (internal).
#include <array>
#include <string_view>
#include <utility>

#include "io/case_config.hpp"

namespace capsflow::io::detail {

template <class E, std::size_t N>
using NameTable = std::array<std::pair<E, std::string_view>, N>;

inline constexpr NameTable<BoundaryType, 5> kBoundaryTypes{{{BoundaryType::wall, "wall"},
                                                            {BoundaryType::moving_wall, "moving_wall"},
                                                            {BoundaryType::inflow, "inflow"},
                                                            {BoundaryType::outflow, "outflow"},
                                                            {BoundaryType::periodic, "periodic"}}};
inline constexpr NameTable<InflowProfile, 4> kInflowProfiles{{{InflowProfile::uniform, "uniform"},
                                                              {InflowProfile::square_duct, "square_duct"},
                                                              {InflowProfile::parabolic, "parabolic"},
                                                              {InflowProfile::pipe, "pipe"}}};
inline constexpr NameTable<MembraneLaw, 2> kMembraneLaws{{{MembraneLaw::skalak, "skalak"},
                                                          {MembraneLaw::neo_hookean, "neo_hookean"}}};
inline constexpr NameTable<InitialShape, 3> kInitialShapes{{{InitialShape::sphere, "sphere"},
                                                            {InitialShape::ellipsoid, "ellipsoid"},
                                                            {InitialShape::inflated, "inflated"}}};
inline constexpr NameTable<KernelType, 3> kKernelTypes{{{KernelType::cosine, "cosine"},
                                                        {KernelType::hat, "hat"},
                                                        {KernelType::peskin4, "peskin4"}}};
inline constexpr NameTable<NodeScheme, 4> kNodeSchemes{{{NodeScheme::euler, "euler"},
                                                        {NodeScheme::ab2, "ab2"},
                                                        {NodeScheme::midpoint, "midpoint"},
                                                        {NodeScheme::bdf2, "bdf2"}}};
inline constexpr NameTable<Coupling, 3> kCouplings{{{Coupling::explicit_forces, "explicit"},
                                                    {Coupling::implicit_forces, "implicit"},
                                                    {Coupling::automatic, "auto"}}};

inline constexpr NameTable<SolidShape, 5> kSolidShapes{{{SolidShape::box, "box"},
                                                        {SolidShape::sphere, "sphere"},
                                                        {SolidShape::cylinder, "cylinder"},
                                                        {SolidShape::tube, "tube"},
                                                        {SolidShape::stl, "stl"}}};
inline constexpr NameTable<SolidCombine, 3> kSolidCombines{{{SolidCombine::unite, "union"},
                                                            {SolidCombine::subtract, "subtract"},
                                                            {SolidCombine::intersect, "intersect"}}};
inline constexpr NameTable<SolidFill, 2> kSolidFills{{{SolidFill::inside, "inside"},
                                                      {SolidFill::outside, "outside"}}};

inline constexpr std::array<std::string_view, 6> kSideNames{"x_lo", "x_hi", "y_lo",
                                                            "y_hi", "z_lo", "z_hi"};
inline constexpr std::array<char, 3> kAxisNames{'x', 'y', 'z'};

template <class E, std::size_t N>
constexpr std::string_view name_of(const NameTable<E, N>& table, E value) {
  for (const auto& [e, s] : table)
    if (e == value) return s;
  return "?";
}

}  // namespace capsflow::io::detail
