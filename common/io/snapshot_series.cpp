#include "io/snapshot_series.hpp"

#include <nlohmann/json.hpp>

#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

#include "io/h5.hpp"

namespace mlcg::io {
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

constexpr SeriesKind kKind{"SnapshotSeries", "snapshot series", "mlcg-snapshot-series", "base", false};

// Connectivity 0..n-1: without it the XDMF3 reader makes points but no cells,
// and ParaView then draws nothing in most representations.
bool conn_is_int32(std::uint64_t n) { return n <= static_cast<std::uint64_t>(std::numeric_limits<std::int32_t>::max()); }

std::string data_item(const std::string& dims, const char* number_type, int precision, const std::string& ref) {
  return "<DataItem Dimensions=\"" + dims + "\" NumberType=\"" + number_type + "\" Precision=\"" +
         std::to_string(precision) + "\" Format=\"HDF\">" + ref + "</DataItem>";
}

}  // namespace

SnapshotSeries::SnapshotSeries(fs::path run_dir, std::string base, bool resume)
    : SeriesIndex(kKind, run_dir, std::move(base)) {
  open(resume);
  rebuild();
}

void SnapshotSeries::write(double time, std::uint64_t step, std::size_t n, const Vec3* x, const Vec3* v,
                           const Vec3* omega, const double* radius, const std::int64_t* id) {
  if (!std::isfinite(time)) throw std::invalid_argument("SnapshotSeries::write: non-finite time");
  if (n > 0 && (!x || !v || !omega || !radius || !id))
    throw std::invalid_argument("SnapshotSeries::write: null field pointer with n > 0");
  const Entry e{start_entry(time), time, step, n};
  {
    H5Writer w(file_path(e));
    w.set_compression(compression());
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
  append(e);
}

void SnapshotSeries::to_json(json& j, const Entry& e) const {
  j = {{"index", e.index}, {"time", e.time}, {"step", e.step}, {"count", e.count}};
}

SnapshotSeries::Entry SnapshotSeries::from_json(const json& j) const {
  return {j.at("index").get<std::uint64_t>(), j.at("time").get<double>(), j.at("step").get<std::uint64_t>(),
          j.at("count").get<std::uint64_t>()};
}

std::string SnapshotSeries::xdmf_grid(const Entry& e, const std::string& file) const {
  const std::string n = std::to_string(e.count), n3 = n + " 3";
  std::string g;
  g += "        <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"" + n + "\" NodesPerElement=\"1\">\n";
  g += "          " + data_item(n, "Int", conn_is_int32(e.count) ? 4 : 8, file + "connectivity") + "\n";
  g += "        </Topology>\n";
  g += "        <Geometry GeometryType=\"XYZ\">\n";
  g += "          " + data_item(n3, "Float", 8, file + "position") + "\n";
  g += "        </Geometry>\n";
  const auto attribute = [&](const char* aname, const char* type, const std::string& dims, const char* nt, int prec) {
    g += std::string("        <Attribute Name=\"") + aname + "\" AttributeType=\"" + type + "\" Center=\"Node\">\n";
    g += "          " + data_item(dims, nt, prec, file + aname) + "\n";
    g += "        </Attribute>\n";
  };
  attribute("radius", "Scalar", n, "Float", 8);
  attribute("velocity", "Vector", n3, "Float", 8);
  attribute("omega", "Vector", n3, "Float", 8);
  attribute("id", "Scalar", n, "Int", 8);
  return g;
}

}  // namespace mlcg::io
