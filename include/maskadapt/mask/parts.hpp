#pragma once
/// \file parts.hpp
/// Body-part groups and part masks.
///
/// The method hides (masks) whole body-part groups: Trunk, Left Arm, Right Arm, Left Leg,
/// Right Leg. A `PartMask` is a 5-bit set; bit p set means part p is masked (hidden from the base
/// policy / adapted by the residual). Names accepted by `PartMask::parse`:
///   trunk, left_arm, right_arm, left_leg, right_leg (single parts),
///   arms (= both arms), legs / lower_body (= both legs), upper_body (= trunk + both arms),
///   none, all; combined with commas: "left_leg,right_leg".
#include <maskadapt/core/error.hpp>

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace maskadapt {

enum class BodyPart : std::uint8_t { Trunk = 0, LeftArm = 1, RightArm = 2, LeftLeg = 3, RightLeg = 4 };
inline constexpr int kNumParts = 5;

inline constexpr std::array<std::string_view, kNumParts> kPartNames = {"trunk", "left_arm", "right_arm",
                                                                       "left_leg", "right_leg"};

inline std::string_view part_name(BodyPart p) { return kPartNames[static_cast<int>(p)]; }

/// The part named `name` (one of kPartNames, not a group), or nothing.
inline std::optional<BodyPart> part_from_name(std::string_view name) {
  for (int p = 0; p < kNumParts; ++p)
    if (name == kPartNames[static_cast<std::size_t>(p)]) return static_cast<BodyPart>(p);
  return std::nullopt;
}

struct PartMask {
  std::uint8_t bits = 0;  ///< bit p ⇔ part p masked

  static constexpr PartMask none() { return {0}; }
  static constexpr PartMask all() { return {(1u << kNumParts) - 1}; }
  static constexpr PartMask of(BodyPart p) { return {static_cast<std::uint8_t>(1u << static_cast<int>(p))}; }

  constexpr bool has(BodyPart p) const { return (bits >> static_cast<int>(p)) & 1u; }
  constexpr bool empty() const { return bits == 0; }
  constexpr int count() const {
    int c = 0;
    for (int p = 0; p < kNumParts; ++p) c += (bits >> p) & 1u;
    return c;
  }
  constexpr PartMask operator|(PartMask o) const { return {static_cast<std::uint8_t>(bits | o.bits)}; }
  constexpr PartMask operator&(PartMask o) const { return {static_cast<std::uint8_t>(bits & o.bits)}; }
  constexpr PartMask operator~() const { return {static_cast<std::uint8_t>(~bits & all().bits)}; }
  constexpr bool operator==(const PartMask&) const = default;

  /// The 5 mask bits as 0/1 floats, in part order (what the policy sees next to s̄).
  template <class T>
  std::array<T, kNumParts> as_array() const {
    std::array<T, kNumParts> a{};
    for (int p = 0; p < kNumParts; ++p) a[p] = has(static_cast<BodyPart>(p)) ? T(1) : T(0);
    return a;
  }

  /// "left_leg,right_leg"; "none" for the empty mask.
  std::string to_string() const {
    if (empty()) return "none";
    std::string s;
    for (int p = 0; p < kNumParts; ++p)
      if (has(static_cast<BodyPart>(p))) {
        if (!s.empty()) s += ",";
        s += kPartNames[p];
      }
    return s;
  }

  /// Parses a comma-separated list of part or group names (see file comment). Throws naming `field`.
  static PartMask parse(std::string_view text, const std::string& field = "mask") {
    PartMask m;
    std::size_t start = 0;
    bool any = false;
    while (start <= text.size()) {
      std::size_t end = text.find(',', start);
      if (end == std::string_view::npos) end = text.size();
      std::string_view tok = text.substr(start, end - start);
      while (!tok.empty() && tok.front() == ' ') tok.remove_prefix(1);
      while (!tok.empty() && tok.back() == ' ') tok.remove_suffix(1);
      if (!tok.empty()) {
        any = true;
        m = m | named(tok, field);
      }
      start = end + 1;
    }
    require(any, "empty mask specification (use 'none' for no masked parts)", {{}, {}, field});
    return m;
  }

 private:
  static PartMask named(std::string_view name, const std::string& field) {
    if (const auto p = part_from_name(name)) return of(*p);
    if (name == "none") return none();
    if (name == "all") return all();
    if (name == "arms") return of(BodyPart::LeftArm) | of(BodyPart::RightArm);
    if (name == "legs" || name == "lower_body") return of(BodyPart::LeftLeg) | of(BodyPart::RightLeg);
    if (name == "upper_body") return of(BodyPart::Trunk) | of(BodyPart::LeftArm) | of(BodyPart::RightArm);
    throw Error("unknown body part '" + std::string(name) +
                    "' (expected trunk, left_arm, right_arm, left_leg, right_leg, arms, legs, lower_body, "
                    "upper_body, none, all)",
                {{}, {}, field});
  }
};

}  // namespace maskadapt
