#include "io/snapshot_series.hpp"

#include <nlohmann/json.hpp>

#include <charconv>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "io/atomic_file.hpp"
#include "io/h5.hpp"

namespace mlcg::io {
namespace fs = std::filesystem;
using nlohmann::json;

namespace detail {

std::string numbered_name(std::string_view base, std::uint64_t index, std::string_view ext) {
  char digits[32];
  std::snprintf(digits, sizeof digits, "%06llu", static_cast<unsigned long long>(index));
  std::string s(base);
  s += '_';
  s += digits;
  s += ext;
  return s;
}

std::string format_double(double v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

void check_series_name(const std::string& name, const char* who) {
  bool ok = !name.empty() && name.front() != '.';
  for (char c : name)
    ok = ok && ((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
                c == '-' || c == '.');
  if (!ok) throw std::invalid_argument(std::string(who) + ": invalid series name '" + name + "' (use [A-Za-z0-9_.-])");
}

std::string xdmf_document(const std::string& name, const std::string& grids) {
  std::string s;
  s += "<?xml version=\"1.0\" encoding=\"utf-8\"?>\n";
  s += "<!DOCTYPE Xdmf SYSTEM \"Xdmf.dtd\" []>\n";
  s += "<Xdmf Version=\"3.0\" xmlns:xi=\"http://www.w3.org/2001/XInclude\">\n";
  s += "  <Domain>\n";
  s += "    <Grid Name=\"" + name + "\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
  s += grids;
  s += "    </Grid>\n";
  s += "  </Domain>\n";
  s += "</Xdmf>\n";
  return s;
}

}  // namespace detail

namespace {

json load_json(const fs::path& p) {
  std::ifstream in(p);
  if (!in) throw std::runtime_error("cannot read '" + p.string() + "'");
  try {
    return json::parse(in);
  } catch (const std::exception& e) {
    throw std::runtime_error("corrupt series index '" + p.string() + "': " + e.what());
  }
}

// Connectivity 0..n-1: without it the XDMF3 reader makes points but no cells,
// and ParaView then draws nothing in most representations.
bool conn_is_int32(std::uint64_t n) { return n <= static_cast<std::uint64_t>(std::numeric_limits<std::int32_t>::max()); }

std::string data_item(const std::string& dims, const char* number_type, int precision, const std::string& ref) {
  return "<DataItem Dimensions=\"" + dims + "\" NumberType=\"" + number_type + "\" Precision=\"" +
         std::to_string(precision) + "\" Format=\"HDF\">" + ref + "</DataItem>";
}

}  // namespace

SnapshotSeries::SnapshotSeries(fs::path run_dir, std::string base, bool resume)
    : run_dir_(std::move(run_dir)), base_(std::move(base)) {
  detail::check_series_name(base_, "SnapshotSeries");
  dir_ = run_dir_ / base_;
  xmf_ = run_dir_ / (base_ + ".xmf");
  index_ = dir_ / "index.json";
  std::error_code ec;
  fs::create_directories(dir_, ec);
  if (ec) throw std::runtime_error("SnapshotSeries: cannot create '" + dir_.string() + "': " + ec.message());
  remove_stale_temps(dir_, base_ + "_");
  remove_stale_temps(dir_, "index.json");
  remove_stale_temps(run_dir_, base_ + ".xmf");

  if (!fs::exists(index_)) return;
  if (!resume)
    throw std::runtime_error("SnapshotSeries: '" + index_.string() +
                             "' already exists; resume the series or use a fresh run directory");
  const json j = load_json(index_);
  try {
    if (j.at("format") != "mlcg-snapshot-series" || j.at("base") != base_)
      throw std::runtime_error("not a snapshot series named '" + base_ + "'");
    for (const auto& e : j.at("entries"))
      entries_.push_back({e.at("index").get<std::uint64_t>(), e.at("time").get<double>(),
                          e.at("step").get<std::uint64_t>(), e.at("count").get<std::uint64_t>()});
  } catch (const std::exception& e) {
    throw std::runtime_error("SnapshotSeries: bad index '" + index_.string() + "': " + e.what());
  }
  if (!entries_.empty()) save_xmf();  // a crash may have left the xmf one entry behind
}

fs::path SnapshotSeries::file_path(const Entry& e) const { return dir_ / detail::numbered_name(base_, e.index, ".h5"); }

void SnapshotSeries::write(double time, std::uint64_t step, std::size_t n, const Vec3* x, const Vec3* v,
                           const Vec3* omega, const double* radius, const std::int64_t* id) {
  if (!std::isfinite(time)) throw std::invalid_argument("SnapshotSeries::write: non-finite time");
  if (n > 0 && (!x || !v || !omega || !radius || !id))
    throw std::invalid_argument("SnapshotSeries::write: null field pointer with n > 0");
  std::size_t k = 0;
  while (k < entries_.size() && entries_[k].time < time) ++k;
  drop_from(k);

  const Entry e{entries_.empty() ? 0 : entries_.back().index + 1, time, step, n};
  {
    H5Writer w(file_path(e));
    w.set_compression(compress_);
    w.write_vec3("position", x, n);
    w.write_vec3("velocity", v, n);
    w.write_vec3("omega", omega, n);
    w.write("radius", radius, n);
    w.write("id", id, n);
    if (conn_is_int32(n)) {
      std::vector<std::int32_t> c(n);
      for (std::size_t i = 0; i < n; ++i) c[i] = static_cast<std::int32_t>(i);
      w.write("connectivity", c);
    } else {
      std::vector<std::int64_t> c(n);
      for (std::size_t i = 0; i < n; ++i) c[i] = static_cast<std::int64_t>(i);
      w.write("connectivity", c);
    }
    w.set_attr("/", "format", "mlcg-particles");
    w.set_attr("/", "version", 1);
    w.set_attr("/", "time", time);
    w.set_attr("/", "step", step);
    w.set_attr("/", "count", static_cast<std::uint64_t>(n));
    w.set_attr("/", "index", e.index);
    w.commit();
  }
  entries_.push_back(e);
  save_index();
  save_xmf();
}

void SnapshotSeries::truncate_after(double time) {
  std::size_t k = 0;
  while (k < entries_.size() && entries_[k].time <= time) ++k;
  drop_from(k);
}

void SnapshotSeries::drop_from(std::size_t k) {
  if (k >= entries_.size()) return;
  const std::vector<Entry> dropped(entries_.begin() + static_cast<std::ptrdiff_t>(k), entries_.end());
  entries_.resize(k);
  // Unlist first, delete after: a crash in between only leaves orphan files.
  save_index();
  std::error_code ec;
  if (entries_.empty()) fs::remove(xmf_, ec);
  else save_xmf();
  for (const Entry& e : dropped) fs::remove(file_path(e), ec);
}

void SnapshotSeries::save_index() const {
  json arr = json::array();
  for (const Entry& e : entries_)
    arr.push_back({{"index", e.index}, {"time", e.time}, {"step", e.step}, {"count", e.count}});
  const json j = {{"format", "mlcg-snapshot-series"}, {"version", 1}, {"base", base_}, {"entries", arr}};
  write_file_atomic(index_, j.dump(1) + "\n");
}

void SnapshotSeries::save_xmf() const {
  std::string g;
  for (const Entry& e : entries_) {
    const std::string name = detail::numbered_name(base_, e.index, "");
    const std::string file = base_ + "/" + name + ".h5:/";
    const std::string n = std::to_string(e.count), n3 = n + " 3";
    g += "      <Grid Name=\"" + name + "\" GridType=\"Uniform\">\n";
    g += "        <Time Value=\"" + detail::format_double(e.time) + "\"/>\n";
    g += "        <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"" + n + "\" NodesPerElement=\"1\">\n";
    g += "          " + data_item(n, "Int", conn_is_int32(e.count) ? 4 : 8, file + "connectivity") + "\n";
    g += "        </Topology>\n";
    g += "        <Geometry GeometryType=\"XYZ\">\n";
    g += "          " + data_item(n3, "Float", 8, file + "position") + "\n";
    g += "        </Geometry>\n";
    const auto attribute = [&](const char* aname, const char* type, const std::string& dims, const char* nt,
                               int prec) {
      g += std::string("        <Attribute Name=\"") + aname + "\" AttributeType=\"" + type + "\" Center=\"Node\">\n";
      g += "          " + data_item(dims, nt, prec, file + aname) + "\n";
      g += "        </Attribute>\n";
    };
    attribute("radius", "Scalar", n, "Float", 8);
    attribute("velocity", "Vector", n3, "Float", 8);
    attribute("omega", "Vector", n3, "Float", 8);
    attribute("id", "Scalar", n, "Int", 8);
    g += "      </Grid>\n";
  }
  write_file_atomic(xmf_, detail::xdmf_document(base_, g));
}

}  // namespace mlcg::io
