#pragma once
// Validators for the flags of every `maskadapt` subcommand. A bad value is rejected while the
// command line is parsed — before anything is loaded, simulated or trained — as a CLI11
// ValidationError that names the flag and the value:
//
//   --envs: must be a positive integer, got 0
//   --mask-prob: must be a number in [0, 1], got nan
//   --preset: must be one of cpu, paper, got 'gpu'
//
// (main.cpp prints it with "Run with --help for more information." and exits with status 105).
// Integers are read strictly in base 10 and handed on in canonical form (integer validators are
// attached with ->transform(), which may rewrite the text): CLI11 alone reads
// "010" as octal 8 and "-1" as 2^64 − 1 for an unsigned option. Real numbers must be finite
// (NaN and ±inf, including overflowing literals such as 1e999, are rejected).
//
// The ranges of the stage-1 flags equal those of train::BaseTrainConfig::validate(), which uses
// the same limits (kMaxEnvs, kMaxThreads, kMaxEpisodeSeconds); docs/training.md lists them all.
#include <maskadapt/core/error.hpp>

#include <CLI/CLI.hpp>

#include <charconv>
#include <cmath>
#include <functional>
#include <limits>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

namespace maskadapt::cli {

namespace detail {
inline std::string number_text(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}
}  // namespace detail

/// Integer in [lo, hi] (base 10, optional leading '+'). It rewrites the text to its canonical
/// decimal form, so attach it with `->transform(...)`: `->check(...)` hands validators a copy.
inline CLI::Validator integer_in(long long lo, long long hi = std::numeric_limits<long long>::max()) {
  // An upper bound that is only the option type's limit (long long or int) is not spelled out
  // in the help text; the error message still states it.
  const bool type_limit = hi == std::numeric_limits<long long>::max() || hi == std::numeric_limits<int>::max();
  std::string what, desc;
  if (type_limit && lo == 1) what = "must be a positive integer", desc = ">= 1";
  else if (type_limit && lo == 0) what = "must be a non-negative integer", desc = ">= 0";
  else if (type_limit) what = "must be an integer >= " + std::to_string(lo), desc = ">= " + std::to_string(lo);
  else what = "must be an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]",
       desc = "[" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
  if (type_limit && hi == std::numeric_limits<int>::max()) what += " (at most " + std::to_string(hi) + ")";
  return CLI::Validator(
      [=](std::string& s) -> std::string {
        const char* b = s.data();
        const char* e = s.data() + s.size();
        if (b != e && *b == '+') ++b;
        long long v = 0;
        const auto [p, ec] = std::from_chars(b, e, v, 10);
        if (b == e || ec != std::errc() || p != e || v < lo || v > hi) return what + ", got '" + s + "'";
        s = std::to_string(v);
        return {};
      },
      desc);
}
inline CLI::Validator positive_integer(long long hi = std::numeric_limits<long long>::max()) { return integer_in(1, hi); }
inline CLI::Validator non_negative_integer(long long hi = std::numeric_limits<long long>::max()) {
  return integer_in(0, hi);
}

/// Finite real number in the interval from lo to hi; `lo_open` / `hi_open` exclude the ends.
inline CLI::Validator real_in(double lo, double hi, bool lo_open = false, bool hi_open = false) {
  const double inf = std::numeric_limits<double>::infinity();
  std::string what;
  if (lo == -inf && hi == inf) what = "must be a finite number";
  else if (hi == inf) what = std::string("must be a finite number ") + (lo_open ? "> " : ">= ") + detail::number_text(lo);
  else
    what = std::string("must be a number in ") + (lo_open ? "(" : "[") + detail::number_text(lo) + ", " +
           detail::number_text(hi) + (hi_open ? ")" : "]");
  std::string desc = what.substr(what.find(' ', 8) + 1);  // drop "must be a"
  return CLI::Validator(
      [=](std::string& s) -> std::string {
        const char* b = s.data();
        const char* e = s.data() + s.size();
        if (b != e && *b == '+') ++b;
        double v = 0;
        const auto [p, ec] = std::from_chars(b, e, v);
        const bool ok = b != e && ec == std::errc() && p == e && std::isfinite(v) && (lo_open ? v > lo : v >= lo) &&
                        (hi_open ? v < hi : v <= hi);
        if (!ok) return what + ", got '" + s + "'";
        return {};
      },
      desc);
}
/// Finite and > 0 (at most `hi` when given).
inline CLI::Validator positive_real(double hi = std::numeric_limits<double>::infinity()) {
  return real_in(0, hi, true, false);
}
inline CLI::Validator non_negative_real() { return real_in(0, std::numeric_limits<double>::infinity()); }
inline CLI::Validator probability() { return real_in(0, 1); }
inline CLI::Validator finite_real() {
  return real_in(-std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity());
}

/// One of a fixed set of names.
inline CLI::Validator one_of(std::vector<std::string> names) {
  std::string list;
  for (const auto& n : names) list += (list.empty() ? "" : ", ") + n;
  std::string bar;
  for (const auto& n : names) bar += (bar.empty() ? "" : "|") + n;
  return CLI::Validator(
      [=](std::string& s) -> std::string {
        for (const auto& n : names)
          if (s == n) return {};
        return "must be one of " + list + ", got '" + s + "'";
      },
      bar);
}

/// A value some library parser accepts: `parse` throws maskadapt::Error for a bad one (e.g.
/// PartMask::parse for mask names, parse_mask_schedule for "0:none,5:lower_body").
inline CLI::Validator parsed_by(std::function<void(const std::string&)> parse, std::string desc) {
  return CLI::Validator(
      [parse](std::string& s) -> std::string {
        try {
          parse(s);
        } catch (const Error& e) {
          return e.message() + ", got '" + s + "'";
        }
        return {};
      },
      std::move(desc));
}

/// Runs `validate` (a config's validate()); an Error about one of the listed config fields is
/// re-thrown naming the flag that sets it, e.g. "field '--iterations (run.iterations)'".
template <class F>
void validate_naming_flags(F&& validate, const std::vector<std::pair<std::string, std::string>>& field_to_flag) {
  try {
    validate();
  } catch (const Error& e) {
    for (const auto& [field, flag] : field_to_flag)
      if (e.context().field == field)
        throw Error(e.message(), {e.context().file, e.context().line, flag + " (" + field + ")"});
    throw;
  }
}

}  // namespace maskadapt::cli
