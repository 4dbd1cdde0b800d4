#include "walls/stl_reader.hpp"

#include <bit>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <algorithm>
#include <cstring>
#include <fstream>
#include <iterator>
#include <stdexcept>
#include <string_view>

namespace mlcg {
namespace {

[[noreturn]] void fail(const std::string& msg) { throw std::runtime_error(msg); }

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path + ": cannot open STL file");
  std::string data((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) fail(path + ": error while reading STL file");
  return data;
}

bool iequal(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i)
    if (std::tolower(static_cast<unsigned char>(a[i])) != std::tolower(static_cast<unsigned char>(b[i])))
      return false;
  return true;
}

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\f' || c == '\v'; }

std::string_view trim(std::string_view s) {
  while (!s.empty() && is_space(s.front())) s.remove_prefix(1);
  while (!s.empty() && is_space(s.back())) s.remove_suffix(1);
  return s;
}

bool starts_with_solid(const std::string& data) {
  size_t i = 0;
  while (i < data.size() && is_space(data[i])) ++i;
  return data.size() - i >= 5 && iequal(std::string_view(data).substr(i, 5), "solid");
}

uint32_t get_u32(const unsigned char* p) {
  return uint32_t(p[0]) | (uint32_t(p[1]) << 8) | (uint32_t(p[2]) << 16) | (uint32_t(p[3]) << 24);
}
float get_f32(const unsigned char* p) { return std::bit_cast<float>(get_u32(p)); }
void put_u32(char* p, uint32_t v) {
  for (int i = 0; i < 4; ++i) p[i] = static_cast<char>((v >> (8 * i)) & 0xffu);
}
void put_f32(char* p, double v) { put_u32(p, std::bit_cast<uint32_t>(static_cast<float>(v))); }

// ---- binary ----------------------------------------------------------------
std::vector<RawTriangle> parse_binary(const std::string& path, const std::string& data) {
  if (data.size() < 84)
    fail(path + ": truncated binary STL: header needs 84 bytes, found " + std::to_string(data.size()));
  const auto* bytes = reinterpret_cast<const unsigned char*>(data.data());
  const uint64_t n = get_u32(bytes + 80);
  const uint64_t need = 84 + 50 * n;
  if (data.size() < need)
    fail(path + ": truncated binary STL: " + std::to_string(n) + " triangles need " + std::to_string(need) +
         " bytes, found " + std::to_string(data.size()));
  if (n == 0) fail(path + ": binary STL contains no triangles");
  std::vector<RawTriangle> tris(n);
  for (uint64_t t = 0; t < n; ++t) {
    const unsigned char* rec = bytes + 84 + 50 * t + 12;  // skip the facet normal
    Vec3* v[3] = {&tris[t].a, &tris[t].b, &tris[t].c};
    for (int k = 0; k < 3; ++k)
      *v[k] = Vec3(get_f32(rec + 12 * k), get_f32(rec + 12 * k + 4), get_f32(rec + 12 * k + 8));
    if (!finite(tris[t].a) || !finite(tris[t].b) || !finite(tris[t].c))
      fail(path + ": binary STL triangle " + std::to_string(t + 1) + " has a non-finite coordinate");
  }
  return tris;
}

// ---- ASCII -----------------------------------------------------------------
class AsciiParser {
 public:
  AsciiParser(const std::string& path, const std::string& data) : path_(path), data_(data) {}

  std::vector<RawTriangle> parse() {
    std::vector<RawTriangle> tris;
    if (!next_line()) fail(path_ + ": empty STL file");
    expect_keyword("solid", "solid <name>");
    while (true) {
      if (!next_line()) break;  // tolerate a missing "endsolid"
      const std::string_view kw = word(0);
      if (iequal(kw, "endsolid")) {
        // Several solids may follow each other.
        if (!next_line()) break;
        expect_keyword("solid", "solid <name>");
        continue;
      }
      if (!iequal(kw, "facet")) expected("facet normal nx ny nz' or 'endsolid");
      RawTriangle t;
      next_or_eof("outer loop");
      if (!iequal(word(0), "outer") || !iequal(word(1), "loop") || nwords_ != 2) expected("outer loop");
      Vec3* v[3] = {&t.a, &t.b, &t.c};
      for (int k = 0; k < 3; ++k) {
        next_or_eof("vertex x y z");
        *v[k] = parse_vertex();
      }
      next_or_eof("endloop");
      if (!iequal(word(0), "endloop") || nwords_ != 1) expected("endloop");
      next_or_eof("endfacet");
      if (!iequal(word(0), "endfacet") || nwords_ != 1) expected("endfacet");
      tris.push_back(t);
    }
    if (tris.empty()) fail(path_ + ": ASCII STL contains no triangles");
    return tris;
  }

 private:
  // Advances to the next non-blank line; false at end of file.
  bool next_line() {
    while (pos_ < data_.size()) {
      size_t end = data_.find('\n', pos_);
      if (end == std::string::npos) end = data_.size();
      line_ = trim(std::string_view(data_).substr(pos_, end - pos_));
      pos_ = end + 1;
      ++lineno_;
      if (!line_.empty()) {
        split();
        return true;
      }
    }
    return false;
  }
  void next_or_eof(const char* what) {
    if (!next_line())
      fail(path_ + ":" + std::to_string(lineno_) + ": expected '" + what + "', found end of file");
  }
  void split() {
    nwords_ = 0;
    size_t i = 0;
    while (i < line_.size()) {
      while (i < line_.size() && is_space(line_[i])) ++i;
      if (i >= line_.size()) break;
      size_t j = i;
      while (j < line_.size() && !is_space(line_[j])) ++j;
      if (nwords_ < kMaxWords) words_[nwords_] = line_.substr(i, j - i);
      ++nwords_;
      i = j;
    }
  }
  std::string_view word(int i) const { return i < nwords_ && i < kMaxWords ? words_[i] : std::string_view(); }
  [[noreturn]] void expected(const char* what) const {
    fail(path_ + ":" + std::to_string(lineno_) + ": expected '" + what + "', found '" + std::string(line_) + "'");
  }
  void expect_keyword(const char* kw, const char* what) const {
    if (!iequal(word(0), kw)) expected(what);
  }
  Vec3 parse_vertex() const {
    if (!iequal(word(0), "vertex") || nwords_ != 4) expected("vertex x y z");
    double c[3];
    for (int k = 0; k < 3; ++k) {
      std::string_view w = word(k + 1);
      if (!w.empty() && w.front() == '+') w.remove_prefix(1);
      auto [ptr, ec] = std::from_chars(w.data(), w.data() + w.size(), c[k]);
      if (ec != std::errc() || ptr != w.data() + w.size() || !std::isfinite(c[k])) expected("vertex x y z");
    }
    return {c[0], c[1], c[2]};
  }

  static constexpr int kMaxWords = 8;
  const std::string& path_;
  const std::string& data_;
  size_t pos_ = 0;
  int lineno_ = 0;
  std::string_view line_;
  std::string_view words_[kMaxWords];
  int nwords_ = 0;
};

}  // namespace

std::vector<RawTriangle> read_stl(const std::string& path) {
  const std::string data = read_file(path);
  if (data.size() >= 84) {
    const uint64_t n = get_u32(reinterpret_cast<const unsigned char*>(data.data()) + 80);
    if (data.size() == 84 + 50 * n) return parse_binary(path, data);
  }
  const bool has_nul = std::memchr(data.data(), '\0', data.size()) != nullptr;
  if (starts_with_solid(data) && !has_nul) return AsciiParser(path, data).parse();
  if (data.empty()) fail(path + ": empty STL file");
  return parse_binary(path, data);
}

namespace {
Vec3 facet_normal(const RawTriangle& t) {
  const Vec3 n = cross(t.b - t.a, t.c - t.a);
  const double l = norm(n);
  return l > 0 ? n / l : Vec3();
}
}  // namespace

void write_stl_ascii(const std::string& path, const std::vector<RawTriangle>& tris,
                     const std::string& solid_name) {
  std::ofstream out(path);
  if (!out) fail(path + ": cannot open for writing");
  char buf[160];
  out << "solid " << solid_name << "\n";
  auto vec = [&](const char* pre, const Vec3& v) {
    std::snprintf(buf, sizeof buf, "%s %.17g %.17g %.17g\n", pre, v.x, v.y, v.z);
    out << buf;
  };
  for (const RawTriangle& t : tris) {
    vec("  facet normal", facet_normal(t));
    out << "    outer loop\n";
    vec("      vertex", t.a);
    vec("      vertex", t.b);
    vec("      vertex", t.c);
    out << "    endloop\n  endfacet\n";
  }
  out << "endsolid " << solid_name << "\n";
  if (!out) fail(path + ": write error");
}

void write_stl_binary(const std::string& path, const std::vector<RawTriangle>& tris, const std::string& header) {
  std::string data(84 + 50 * tris.size(), '\0');
  std::memcpy(data.data(), header.data(), std::min<size_t>(header.size(), 80));
  put_u32(data.data() + 80, static_cast<uint32_t>(tris.size()));
  for (size_t t = 0; t < tris.size(); ++t) {
    char* rec = data.data() + 84 + 50 * t;
    const Vec3 v[4] = {facet_normal(tris[t]), tris[t].a, tris[t].b, tris[t].c};
    for (int k = 0; k < 4; ++k)
      for (int c = 0; c < 3; ++c) put_f32(rec + 12 * k + 4 * c, v[k][c]);
  }
  std::ofstream out(path, std::ios::binary);
  if (!out) fail(path + ": cannot open for writing");
  out.write(data.data(), static_cast<std::streamsize>(data.size()));
  if (!out) fail(path + ": write error");
}

}  // namespace mlcg
