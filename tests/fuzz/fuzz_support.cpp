#include "fuzz_support.hpp"

#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <stdexcept>
#include <string_view>
#include <vector>

#include "config/case_parser.hpp"
#include "io/h5.hpp"
#include "level/level.hpp"

namespace fs = std::filesystem;

namespace mlcg::fuzz {
namespace {

void remove_scratch() {
  std::error_code ec;
  fs::remove_all(scratch(), ec);
}

// Reads little-endian unsigned integers and byte runs off an input; `ok` turns false when it ends early.
struct Cursor {
  const uint8_t* p;
  const uint8_t* end;
  bool ok = true;
  uint64_t uint(int bytes) {
    uint64_t v = 0;
    if (end - p < bytes) ok = false;
    for (int i = 0; ok && i < bytes; ++i) v |= uint64_t{*p++} << (8 * i);
    return v;
  }
  std::string_view run(uint64_t n) {
    if (static_cast<uint64_t>(end - p) < n) ok = false;
    if (!ok) return {};
    const std::string_view r(reinterpret_cast<const char*>(p), n);
    p += n;
    return r;
  }
};

template <class T>
std::vector<T> values(std::string_view bytes) {
  std::vector<T> v(bytes.size() / sizeof(T));
  if (!v.empty()) std::memcpy(v.data(), bytes.data(), v.size() * sizeof(T));
  return v;
}

template <class T>
void write_dataset(io::H5Writer& w, const std::string& name, std::string_view bytes, uint8_t columns) {
  const auto v = values<T>(bytes);
  if (columns > 1 && v.size() % columns == 0)
    w.write_shaped(name, v.data(), {v.size() / columns, columns});
  else
    w.write(name, v);
}

void write_attribute(io::H5Writer& w, const std::string& name, H5Type type, std::string_view bytes) {
  const size_t at = name.find('@');
  if (at == std::string::npos) return;
  const std::string obj = name.substr(0, at), attr = name.substr(at + 1);
  const auto first = [&](auto zero) {
    const auto v = values<decltype(zero)>(bytes);
    return v.empty() ? zero : v.front();
  };
  switch (type) {
    case H5Type::F64: w.set_attr(obj, attr, first(0.0)); break;
    case H5Type::U64: w.set_attr(obj, attr, first(uint64_t{0})); break;
    case H5Type::String: w.set_attr(obj, attr, bytes); break;
    default: w.set_attr(obj, attr, first(int64_t{0})); break;
  }
}

void write_entry(io::H5Writer& w, H5Kind kind, H5Type type, uint8_t columns, const std::string& name,
                 std::string_view bytes) {
  if (kind == H5Kind::Group) return w.create_group(name);
  if (kind == H5Kind::Attribute) return write_attribute(w, name, type, bytes);
  switch (type) {
    case H5Type::F64: return write_dataset<double>(w, name, bytes, columns);
    case H5Type::I64: return write_dataset<int64_t>(w, name, bytes, columns);
    case H5Type::I32: return write_dataset<int32_t>(w, name, bytes, columns);
    case H5Type::U64: return write_dataset<uint64_t>(w, name, bytes, columns);
    default: return write_dataset<uint8_t>(w, name, bytes, columns);
  }
}

}  // namespace

void write_h5_content(const fs::path& file, const uint8_t* data, size_t size) {
  io::H5Writer w(file);
  Cursor c{data, data + size};
  for (;;) {
    const auto kind = c.uint(1), type = c.uint(1), columns = c.uint(1);
    const std::string name(c.run(c.uint(2)));
    const std::string_view bytes = c.run(c.uint(4));
    if (!c.ok) break;
    try {
      write_entry(w, static_cast<H5Kind>(kind % 3), static_cast<H5Type>(type % 6), static_cast<uint8_t>(columns), name,
                  bytes);
    } catch (const std::runtime_error&) {  // a name or shape H5Writer refuses: the entry is left out
    }
  }
  w.commit();
}

void append_h5_entry(std::string& content, H5Kind kind, H5Type type, uint8_t columns, const std::string& name,
                     std::string_view bytes) {
  const auto put = [&](uint64_t v, int n) {
    for (int i = 0; i < n; ++i) content.push_back(static_cast<char>((v >> (8 * i)) & 0xff));
  };
  put(static_cast<uint8_t>(kind), 1);
  put(static_cast<uint8_t>(type), 1);
  put(columns, 1);
  put(name.size(), 2);
  content += name;
  put(bytes.size(), 4);
  content += bytes;
}

fs::path source(const std::string& relative) { return fs::path(MLCG_SOURCE_DIR) / relative; }

fs::path scratch(const std::string& sub) {
  // Never destroyed: remove_scratch runs after the destructors of statics made before it was registered.
  static const fs::path& root = *[] {
    const char* tmp = std::getenv("TMPDIR");
    const auto* r = new fs::path(fs::path(tmp && *tmp ? tmp : "/tmp") / ("mlcg-fuzz-" + std::to_string(getpid())));
    fs::create_directories(*r);
    std::atexit(remove_scratch);
    return r;
  }();
  if (sub.empty()) return root;
  fs::create_directories(root / sub);
  return root / sub;
}

void write_file(const fs::path& path, const uint8_t* data, size_t size) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  if (!out) throw std::runtime_error("fuzz: cannot write " + path.string());
}

void write_file(const fs::path& path, std::string_view text) {
  write_file(path, reinterpret_cast<const uint8_t*>(text.data()), text.size());
}

void run_level(const config::CaseSpec& cs, const fs::path& restart) {
  LevelOptions opt;
  opt.restart = restart;
  opt.quiet = true;
  opt.single_rank = true;
  try {
    Level level(cs, opt);
    level.step_once();
    level.step_once();
  } catch (const std::runtime_error&) {
  }
}

config::CaseSpec shipped_case(const std::string& relative) { return config::load_case(source(relative).string()); }

const CouplerSetup& quickstart_coupler() {
  static const CouplerSetup s = [] {
    CouplerSetup c;
    c.cs = shipped_case("cases/quickstart/mlcg.toml");
    c.cc = coupling::coupling_from_case(c.cs);
    return c;
  }();
  return s;
}

std::vector<bus::IntervalStats> plausible_stats(const coupling::Coupler& c, uint64_t k) {
  std::vector<bus::IntervalStats> st(c.config().levels.size());
  for (auto& s : st) s.set_interval(k);
  for (size_t r = 0; r < c.config().regions.size(); ++r) {
    const auto& geo = c.geometry(r);
    const auto& grid = c.config().regions[r].grid;
    const size_t bins = c.config().regions[r].planner.radius_bins.size() - 1;
    for (const bool coarse : {true, false}) {
      auto* g = st[coarse ? grid.coarse_level() : grid.fine_level()].add_grids();
      g->set_grid(static_cast<uint32_t>(r));
      for (size_t cell = 0; cell < geo.cells(); ++cell) {
        for (double s : {200.0, 200.0, 400.0, 0.0, 0.0, 0.0}) g->add_cell_stress(s);
        g->add_cell_volume_fraction(0.55);
        for (double v : {0.0, 0.0, -0.1}) g->add_cell_velocity(v);
        g->add_cell_max_speed(0.3);
      }
      if (!coarse) {
        g->set_occupants_sent(true);
        continue;
      }
      const double mass = 2e-4;  // kg per face and interval: a few fine particles
      for (size_t f = 0; f < geo.faces(); ++f) {
        Vec3 lo, hi;
        geo.face_slab(f, 0.0, lo, hi);
        const Vec3 centre = 0.5 * (lo + hi);
        g->add_face_mass(mass);
        for (double q : {0.0, 0.0, -0.1 * mass}) g->add_face_momentum(q);
        for (double q : {mass * centre.x, mass * centre.y, mass * centre.z}) g->add_face_moment(q);
        for (size_t b = 0; b < bins; ++b) g->add_face_histogram(b == 0 ? 1 : 0);
      }
    }
  }
  return st;
}

}  // namespace mlcg::fuzz
