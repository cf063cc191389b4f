#pragma once
/// \file bvh.hpp
/// Biovision Hierarchy (BVH) motion files: reader, writer and forward kinematics in the file's
/// own terms (its units, its up axis, its channel orders).
///
/// What the reader accepts (real files differ in all of these):
///  - any channel order per joint, position channels on any joint (LAFAN1 has them everywhere);
///  - spaces, tabs, LF / CR LF / mixed line endings, blank lines, `#` and `//` line comments
///    in the hierarchy, keywords in any letter case;
///  - numbers as `strtod` reads them: `.0083333`, `1.9097e-14`, `-0`;
///  - `Frames:` / `Frame Time:` followed by spaces or tabs.
/// Everything malformed (missing braces, wrong channel count, unknown channel, short or long data
/// rows, non-numeric or non-finite values, a `Frames:` count that does not match the rows,
/// missing MOTION) throws maskadapt::Error naming the file and the 1-based line.
///
/// Conventions:
///  - a joint's local rotation is the product of its rotation channels in the order listed:
///    `Zrotation Xrotation Yrotation` ⇒ R = R_z · R_x · R_y (angles in degrees in the file);
///  - a joint's local translation is its OFFSET, with each axis that has a position channel
///    replaced by that channel's value (root: absolute position; LAFAN1: values ≈ offsets);
///  - End Sites are kept as joints without channels (named `<parent>_End`), so toe and head
///    tips take part in kinematics (grounding, foot contacts).
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/types.hpp>

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

namespace maskadapt::bvh {

/// One BVH channel: a translation or rotation about a coordinate axis.
enum class Channel : std::uint8_t { Xposition, Yposition, Zposition, Xrotation, Yrotation, Zrotation };

inline constexpr bool is_rotation(Channel c) { return static_cast<int>(c) >= 3; }
inline constexpr int channel_axis(Channel c) { return static_cast<int>(c) % 3; }

inline std::string_view channel_name(Channel c) {
  static constexpr std::string_view names[] = {"Xposition", "Yposition", "Zposition",
                                               "Xrotation", "Yrotation", "Zrotation"};
  return names[static_cast<int>(c)];
}

struct Joint {
  std::string name;               ///< joint name; End Sites are "<parent>_End"
  int parent = -1;                ///< index of the parent joint, −1 for the root
  Vec3 offset = Vec3::Zero();     ///< OFFSET in the parent's frame (file units)
  std::vector<Channel> channels;  ///< channels in file order (empty for End Sites)
  int first_channel = 0;          ///< column of channels[0] in a data row
  bool end_site = false;          ///< true for an End Site
};

/// A parsed BVH file. Joints are in file order, so parents precede children.
struct Motion {
  std::vector<Joint> joints;
  double frame_time = 1.0 / 30.0;  ///< seconds per frame
  MatrixXd frames;                 ///< (num_channels × num_frames) raw channel values (file units, degrees)

  int num_joints() const { return static_cast<int>(joints.size()); }
  int num_channels() const { return static_cast<int>(frames.rows()); }
  int num_frames() const { return static_cast<int>(frames.cols()); }
  double fps() const { return 1.0 / frame_time; }

  /// Index of a joint by name, −1 if absent.
  int find(std::string_view name) const {
    for (int i = 0; i < num_joints(); ++i)
      if (joints[i].name == name) return i;
    return -1;
  }
};

/// Product of rotations about the listed axes, in the listed order (angles in degrees).
inline Quat rotation_from_channels(const std::vector<Channel>& channels, const double* values) {
  Quat r = Quat::Identity();
  for (std::size_t c = 0; c < channels.size(); ++c) {
    if (!is_rotation(channels[c])) continue;
    const double a = values[c] * (M_PI / 180.0);
    r = r * Quat(Eigen::AngleAxisd(a, Vec3::Unit(channel_axis(channels[c]))));
  }
  return r;
}

/// Local translation and rotation of joint j in frame f (file units).
inline void local_transform(const Motion& m, int j, int f, Vec3& translation, Quat& rotation) {
  const Joint& jt = m.joints[j];
  translation = jt.offset;
  if (jt.channels.empty()) {
    rotation = Quat::Identity();
    return;
  }
  const double* v = m.frames.col(f).data() + jt.first_channel;
  for (std::size_t c = 0; c < jt.channels.size(); ++c)
    if (!is_rotation(jt.channels[c])) translation[channel_axis(jt.channels[c])] = v[c];
  rotation = rotation_from_channels(jt.channels, v);
}

/// World positions (3 × num_joints, file units) and rotations of every joint in frame f.
inline void forward_kinematics(const Motion& m, int f, Matrix3X& pos, std::vector<Quat>& rot) {
  const int nj = m.num_joints();
  pos.resize(3, nj);
  rot.resize(nj);
  for (int j = 0; j < nj; ++j) {
    Vec3 t;
    Quat r;
    local_transform(m, j, f, t, r);
    const int p = m.joints[j].parent;
    if (p < 0) {
      pos.col(j) = t;
      rot[j] = r;
    } else {
      pos.col(j) = pos.col(p) + rot[p] * t;
      rot[j] = rot[p] * r;
    }
  }
}

namespace detail {

/// Splits text into whitespace-separated tokens, remembering each token's line.
class Lexer {
 public:
  Lexer(std::string_view text, std::string file) : text_(text), file_(std::move(file)) {}

  struct Token {
    std::string_view text;
    long long line = 0;
  };

  /// Next token of the hierarchy (skips whitespace and comments); empty text at end of input.
  Token next() {
    skip_space();
    Token t{{}, line_};
    const std::size_t start = pos_;
    while (pos_ < text_.size() && !is_space(text_[pos_])) ++pos_;
    t.text = text_.substr(start, pos_ - start);
    return t;
  }
  Token expect(const char* what) {
    Token t = next();
    if (t.text.empty()) fail("unexpected end of file: expected " + std::string(what), t.line);
    return t;
  }

  /// The rest of the current line (after the last token), for data rows.
  std::string_view rest_of_line() {
    const std::size_t start = pos_;
    while (pos_ < text_.size() && text_[pos_] != '\n') ++pos_;
    return text_.substr(start, pos_ - start);
  }
  /// Next line of data (without its terminator); returns false at end of input.
  bool next_line(std::string_view& line, long long& line_no) {
    // step past the terminator of the current line
    if (pos_ < text_.size() && text_[pos_] == '\n') {
      ++pos_;
      ++line_;
    }
    if (pos_ >= text_.size()) return false;
    line_no = line_;
    line = rest_of_line();
    return true;
  }

  [[noreturn]] void fail(const std::string& msg, long long line) const {
    throw Error(msg, {file_, line, {}});
  }
  const std::string& file() const { return file_; }
  long long line() const { return line_; }

  static bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\v' || c == '\f'; }

 private:
  void skip_space() {
    for (;;) {
      while (pos_ < text_.size() && is_space(text_[pos_])) {
        if (text_[pos_] == '\n') ++line_;
        ++pos_;
      }
      if (pos_ < text_.size() &&
          (text_[pos_] == '#' || (text_[pos_] == '/' && pos_ + 1 < text_.size() && text_[pos_ + 1] == '/'))) {
        while (pos_ < text_.size() && text_[pos_] != '\n') ++pos_;
        continue;
      }
      return;
    }
  }

  std::string_view text_;
  std::string file_;
  std::size_t pos_ = 0;
  long long line_ = 1;
};

inline bool iequals(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (std::tolower(static_cast<unsigned char>(a[i])) != std::tolower(static_cast<unsigned char>(b[i])))
      return false;
  return true;
}

/// Parses a whole token as a finite double (strtod syntax), or fails naming the line.
inline double to_double(std::string_view tok, const Lexer& lx, long long line, const char* what) {
  char buf[64];
  if (tok.empty() || tok.size() >= sizeof(buf))
    lx.fail(std::string("expected a number for ") + what + ", got '" + std::string(tok.substr(0, 40)) + "'", line);
  tok.copy(buf, tok.size());
  buf[tok.size()] = '\0';
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(buf, &end);
  if (end != buf + tok.size() || !std::isfinite(v))
    lx.fail(std::string("expected a finite number for ") + what + ", got '" + std::string(tok) + "'", line);
  return v;
}

inline bool parse_channel(std::string_view s, Channel& c) {
  static constexpr std::string_view names[] = {"Xposition", "Yposition", "Zposition",
                                               "Xrotation", "Yrotation", "Zrotation"};
  for (int i = 0; i < 6; ++i)
    if (iequals(s, names[i])) {
      c = static_cast<Channel>(i);
      return true;
    }
  return false;
}

}  // namespace detail

/// Parses BVH text. `file` is used in error messages only.
inline Motion parse(std::string_view text, const std::string& file = "<bvh>") {
  using detail::iequals;
  detail::Lexer lx(text, file);
  Motion m;

  auto tok = lx.expect("HIERARCHY");
  if (!iequals(tok.text, "HIERARCHY")) lx.fail("expected HIERARCHY, got '" + std::string(tok.text.substr(0, 40)) + "'", tok.line);

  // ---- hierarchy: a stack of open joints ----
  std::vector<int> stack;       // joint index for each open brace
  int num_channels = 0;
  int pending = -1;             // joint declared, waiting for '{'
  bool seen_root = false;
  constexpr int kMaxJoints = 10000;
  constexpr std::size_t kMaxDepth = 256;  // keeps the writer's recursion shallow
  for (;;) {
    tok = lx.expect("a joint, '}' or MOTION");
    const auto& t = tok.text;
    if (pending >= 0) {
      if (t != "{") lx.fail("expected '{' after joint '" + m.joints[pending].name + "'", tok.line);
      if (stack.size() >= kMaxDepth) lx.fail("hierarchy nested deeper than " + std::to_string(kMaxDepth) + " joints", tok.line);
      stack.push_back(pending);
      pending = -1;
      continue;
    }
    if (iequals(t, "ROOT") || iequals(t, "JOINT") || iequals(t, "End")) {
      const bool end = iequals(t, "End");
      if (iequals(t, "ROOT")) {
        if (seen_root) lx.fail("a second ROOT (only one skeleton per file is supported)", tok.line);
        if (!stack.empty()) lx.fail("ROOT inside another joint", tok.line);
        seen_root = true;
      } else if (stack.empty()) {
        lx.fail(std::string(end ? "End Site" : "JOINT") + " outside of any joint (missing ROOT or extra '}')", tok.line);
      } else if (m.joints[stack.back()].end_site) {
        lx.fail("an End Site cannot have children", tok.line);
      }
      auto name = lx.expect("a joint name");
      if (end && !iequals(name.text, "Site")) lx.fail("expected 'End Site'", name.line);
      if (name.text == "{") lx.fail("missing joint name", name.line);
      if (static_cast<int>(m.joints.size()) >= kMaxJoints) lx.fail("too many joints", tok.line);
      Joint j;
      j.parent = stack.empty() ? -1 : stack.back();
      j.end_site = end;
      j.name = end ? m.joints[j.parent].name + "_End" : std::string(name.text);
      j.first_channel = num_channels;
      m.joints.push_back(std::move(j));
      pending = static_cast<int>(m.joints.size()) - 1;
      continue;
    }
    if (iequals(t, "OFFSET")) {
      if (stack.empty()) lx.fail("OFFSET outside of any joint", tok.line);
      Joint& j = m.joints[stack.back()];
      for (int a = 0; a < 3; ++a) {
        auto v = lx.expect("an OFFSET value");
        if (v.line != tok.line) lx.fail("OFFSET needs 3 values on its line", tok.line);
        j.offset[a] = detail::to_double(v.text, lx, v.line, "OFFSET");
      }
      continue;
    }
    if (iequals(t, "CHANNELS")) {
      if (stack.empty()) lx.fail("CHANNELS outside of any joint", tok.line);
      Joint& j = m.joints[stack.back()];
      if (j.end_site) lx.fail("an End Site cannot have CHANNELS", tok.line);
      if (!j.channels.empty()) lx.fail("joint '" + j.name + "' has two CHANNELS lines", tok.line);
      auto nt = lx.expect("a channel count");
      const double n = detail::to_double(nt.text, lx, nt.line, "CHANNELS count");
      if (n != std::floor(n) || n < 0 || n > 6)
        lx.fail("CHANNELS count must be an integer in 0..6, got '" + std::string(nt.text) + "'", nt.line);
      const std::string_view line_rest = lx.rest_of_line();
      // the channel names must be on the same line: count them there
      std::vector<std::string_view> names;
      std::size_t p = 0;
      while (p < line_rest.size()) {
        while (p < line_rest.size() && detail::Lexer::is_space(line_rest[p])) ++p;
        const std::size_t s = p;
        while (p < line_rest.size() && !detail::Lexer::is_space(line_rest[p])) ++p;
        if (p > s) names.push_back(line_rest.substr(s, p - s));
      }
      if (static_cast<int>(names.size()) != static_cast<int>(n))
        lx.fail("CHANNELS " + std::string(nt.text) + " of joint '" + j.name + "' lists " +
                    std::to_string(names.size()) + " channel names",
                tok.line);
      bool used[6] = {};
      for (auto s : names) {
        Channel c;
        if (!detail::parse_channel(s, c)) lx.fail("unknown channel '" + std::string(s.substr(0, 40)) + "'", tok.line);
        if (used[static_cast<int>(c)]) lx.fail("channel '" + std::string(s) + "' listed twice", tok.line);
        used[static_cast<int>(c)] = true;
        j.channels.push_back(c);
      }
      j.first_channel = num_channels;
      num_channels += static_cast<int>(n);
      continue;
    }
    if (t == "}") {
      if (stack.empty()) lx.fail("unmatched '}'", tok.line);
      stack.pop_back();
      continue;
    }
    if (t == "{") lx.fail("unexpected '{'", tok.line);
    if (iequals(t, "MOTION")) {
      if (!stack.empty())
        lx.fail("MOTION before the hierarchy is closed: missing '}' for joint '" + m.joints[stack.back()].name + "'",
                tok.line);
      if (!seen_root) lx.fail("MOTION before any ROOT", tok.line);
      break;
    }
    lx.fail("unexpected '" + std::string(t.substr(0, 40)) + "' in the hierarchy", tok.line);
  }
  // channel offsets must follow declaration order (they do: assigned while parsing)

  // ---- motion header ----
  tok = lx.expect("Frames:");
  long long frames_line = tok.line;
  if (iequals(tok.text, "Frames")) {
    auto colon = lx.expect("':'");
    if (colon.text != ":") lx.fail("expected 'Frames:'", colon.line);
  } else if (!iequals(tok.text, "Frames:")) {
    lx.fail("expected 'Frames:', got '" + std::string(tok.text.substr(0, 40)) + "'", tok.line);
  }
  auto nt = lx.expect("the frame count");
  const double nframes_d = detail::to_double(nt.text, lx, nt.line, "Frames");
  if (nframes_d < 0 || nframes_d != std::floor(nframes_d) || nframes_d > 1e8)
    lx.fail("Frames must be a non-negative integer, got '" + std::string(nt.text) + "'", nt.line);
  const auto nframes = static_cast<long long>(nframes_d);

  tok = lx.expect("Frame Time:");
  if (!iequals(tok.text, "Frame")) lx.fail("expected 'Frame Time:', got '" + std::string(tok.text.substr(0, 40)) + "'", tok.line);
  tok = lx.expect("Time:");
  if (iequals(tok.text, "Time")) {
    auto colon = lx.expect("':'");
    if (colon.text != ":") lx.fail("expected 'Frame Time:'", colon.line);
  } else if (!iequals(tok.text, "Time:")) {
    lx.fail("expected 'Frame Time:'", tok.line);
  }
  auto ft = lx.expect("the frame time");
  m.frame_time = detail::to_double(ft.text, lx, ft.line, "Frame Time");
  if (!(m.frame_time > 0.0)) lx.fail("Frame Time must be positive, got '" + std::string(ft.text) + "'", ft.line);
  {
    auto rest = lx.rest_of_line();
    for (char c : rest)
      if (!detail::Lexer::is_space(c)) lx.fail("unexpected text after Frame Time", ft.line);
  }

  // ---- data rows: one frame per non-blank line ----
  // Reserve by what the remaining text could possibly hold, not by a claimed count.
  m.frames.resize(num_channels, 0);
  std::vector<double> values;
  values.reserve(static_cast<std::size_t>(std::min<long long>(nframes, 1 << 20)) * std::max(num_channels, 1));
  long long rows = 0;
  std::string_view line;
  long long line_no = 0;
  while (lx.next_line(line, line_no)) {
    std::size_t p = 0;
    int count = 0;
    bool blank = true;
    while (p < line.size()) {
      while (p < line.size() && detail::Lexer::is_space(line[p])) ++p;
      const std::size_t s = p;
      while (p < line.size() && !detail::Lexer::is_space(line[p])) ++p;
      if (p == s) break;
      blank = false;
      if (rows >= nframes)
        lx.fail("more data rows than 'Frames: " + std::to_string(nframes) + "'", line_no);
      if (count >= num_channels)
        lx.fail("data row has more than the " + std::to_string(num_channels) + " values the hierarchy declares",
                line_no);
      values.push_back(detail::to_double(line.substr(s, p - s), lx, line_no, "a channel value"));
      ++count;
    }
    if (blank) continue;
    if (count != num_channels)
      lx.fail("data row has " + std::to_string(count) + " values, the hierarchy declares " +
                  std::to_string(num_channels) + " channels",
              line_no);
    ++rows;
  }
  if (rows != nframes)
    lx.fail("'Frames: " + std::to_string(nframes) + "' but the file has " + std::to_string(rows) + " data rows",
            frames_line);
  if (num_channels > 0)
    m.frames = Eigen::Map<const MatrixXd>(values.data(), num_channels, static_cast<Index>(rows));
  else
    m.frames.resize(0, static_cast<Index>(rows));
  return m;
}

/// Reads a BVH file; errors name the path and line.
inline Motion read(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  require(static_cast<bool>(in), "cannot open BVH file", {path, std::nullopt, {}});
  std::ostringstream ss;
  ss << in.rdbuf();
  return parse(ss.str(), path);
}

/// Serialises a motion as BVH text. `digits`: significant digits of every value (9 keeps
/// read → write → read within ~1e-8 relative).
inline std::string to_string(const Motion& m, int digits = 9) {
  require(m.num_joints() > 0 && m.joints[0].parent == -1, "motion has no root joint", {{}, {}, "joints"});
  std::string out;
  out.reserve(static_cast<std::size_t>(m.frames.size()) * 12 + 4096);
  char buf[64];
  auto num = [&](double v) {
    std::snprintf(buf, sizeof(buf), "%.*g", digits, v == 0.0 ? 0.0 : v);
    out += buf;
  };
  out += "HIERARCHY\n";
  // children lists
  std::vector<std::vector<int>> children(m.joints.size());
  for (int j = 1; j < m.num_joints(); ++j) {
    require(m.joints[j].parent >= 0 && m.joints[j].parent < j, "joint parents must precede children",
            {{}, {}, m.joints[j].name});
    children[m.joints[j].parent].push_back(j);
  }
  int expected_channel = 0;
  auto write_joint = [&](auto&& self, int j, int depth) -> void {
    const Joint& jt = m.joints[j];
    const std::string ind(depth, '\t');
    if (jt.end_site) {
      out += ind + "End Site\n";
    } else {
      out += ind + (jt.parent < 0 ? "ROOT " : "JOINT ") + jt.name + "\n";
    }
    out += ind + "{\n" + ind + "\tOFFSET ";
    for (int a = 0; a < 3; ++a) {
      num(jt.offset[a]);
      out += a < 2 ? " " : "\n";
    }
    if (!jt.end_site) {
      require(jt.first_channel == expected_channel, "channel columns must follow the hierarchy order",
              {{}, {}, jt.name});
      expected_channel += static_cast<int>(jt.channels.size());
      out += ind + "\tCHANNELS " + std::to_string(jt.channels.size());
      for (auto c : jt.channels) out += " " + std::string(channel_name(c));
      out += "\n";
    }
    for (int c : children[j]) self(self, c, depth + 1);
    out += ind + "}\n";
  };
  write_joint(write_joint, 0, 0);
  require(expected_channel == m.num_channels(), "frames have " + std::to_string(m.num_channels()) +
                                                    " rows but the joints declare " + std::to_string(expected_channel) +
                                                    " channels",
          {{}, {}, "frames"});
  out += "MOTION\nFrames: " + std::to_string(m.num_frames()) + "\nFrame Time: ";
  num(m.frame_time);
  out += "\n";
  for (int f = 0; f < m.num_frames(); ++f) {
    for (int c = 0; c < m.num_channels(); ++c) {
      if (c) out += ' ';
      num(m.frames(c, f));
    }
    out += '\n';
  }
  return out;
}

/// Writes a BVH file (Blender: File ▸ Import ▸ Motion Capture (.bvh)).
inline void write(const std::string& path, const Motion& m, int digits = 9) {
  require_finite(m.frames, "frames", path);
  const std::string text = to_string(m, digits);
  std::ofstream out(path, std::ios::binary);
  require(static_cast<bool>(out), "cannot open file for writing", {path, std::nullopt, {}});
  out << text;
  require(static_cast<bool>(out), "write failed", {path, std::nullopt, {}});
}

}  // namespace maskadapt::bvh
