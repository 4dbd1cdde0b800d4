#include "io/grid_series.hpp"

#include <nlohmann/json.hpp>

#include <cmath>
#include <stdexcept>

#include "io/h5.hpp"

namespace mlcg::io {
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

constexpr SeriesKind kKind{"GridSeries", "grid series", "mlcg-grid-series", "name", true};

// Solver order xx yy zz xy xz yz -> XDMF Tensor6 order xx xy xz yy yz zz.
constexpr int kToXdmf[6] = {0, 3, 4, 1, 5, 2};

bool same_spec(const GridSpec& a, const GridSpec& b) {
  return a.origin == b.origin && a.h == b.h && a.nx == b.nx && a.ny == b.ny && a.nz == b.nz;
}

std::string spec_text(const GridSpec& s) {
  return "origin (" + detail::format_double(s.origin.x) + ", " + detail::format_double(s.origin.y) + ", " +
         detail::format_double(s.origin.z) + "), h " + detail::format_double(s.h) + ", dims " +
         std::to_string(s.nx) + "x" + std::to_string(s.ny) + "x" + std::to_string(s.nz);
}

}  // namespace

GridSeries::GridSeries(fs::path run_dir, std::string name, const GridSpec& spec, bool resume)
    : SeriesIndex(kKind, run_dir / "grids", std::move(name)), spec_(spec) {
  if (spec_.nx < 1 || spec_.ny < 1 || spec_.nz < 1 || !(spec_.h > 0.0) || !std::isfinite(spec_.h) ||
      !finite(spec_.origin))
    throw std::invalid_argument("GridSeries '" + this->name() + "': invalid grid " + spec_text(spec_));
  GridSpec old;
  const bool resumed = open(resume, [&](const json& j) {
    const json& g = j.at("grid");
    old.origin = {g.at("origin").at(0).get<double>(), g.at("origin").at(1).get<double>(),
                  g.at("origin").at(2).get<double>()};
    old.h = g.at("h").get<double>();
    old.nx = g.at("dims").at(0).get<int>();
    old.ny = g.at("dims").at(1).get<int>();
    old.nz = g.at("dims").at(2).get<int>();
  });
  // Checked before rebuild(), which would describe the old files with the new grid.
  if (resumed && !same_spec(old, spec_))
    throw std::runtime_error("GridSeries '" + this->name() + "': cannot resume, recorded grid " + spec_text(old) +
                             " differs from requested " + spec_text(spec_));
  rebuild();
}

void GridSeries::write(double time, const std::vector<double>& volume_fraction, const std::vector<Vec3>& mean_velocity,
                       const std::vector<double>& max_speed, const std::vector<double>& stress6,
                       const std::vector<double>& count) {
  const std::size_t nc = spec_.cells();
  if (!std::isfinite(time)) throw std::invalid_argument("GridSeries::write: non-finite time");
  const auto need = [&](std::size_t got, std::size_t want, const char* what) {
    if (got != want)
      throw std::invalid_argument("GridSeries '" + name() + "'::write: " + what + " has " + std::to_string(got) +
                                  " values, expected " + std::to_string(want));
  };
  need(volume_fraction.size(), nc, "volume_fraction");
  need(mean_velocity.size(), nc, "mean_velocity");
  need(max_speed.size(), nc, "max_speed");
  need(stress6.size(), 6 * nc, "stress6");
  need(count.size(), nc, "count");

  const Entry e{start_entry(time), time};

  std::vector<double> stress(6 * nc);
  for (std::size_t c = 0; c < nc; ++c)
    for (int i = 0; i < 6; ++i) stress[6 * c + i] = stress6[6 * c + kToXdmf[i]];

  const std::uint64_t nz = spec_.nz, ny = spec_.ny, nx = spec_.nx;
  {
    H5Writer w(file_path(e));
    w.set_compression(compression());
    w.write_shaped("volume_fraction", volume_fraction.data(), {nz, ny, nx});
    w.write_shaped("mean_velocity", reinterpret_cast<const double*>(mean_velocity.data()), {nz, ny, nx, 3});
    w.write_shaped("max_speed", max_speed.data(), {nz, ny, nx});
    w.write_shaped("stress", stress.data(), {nz, ny, nx, 6});
    w.set_attr("stress", "components", "xx xy xz yy yz zz");
    w.write_shaped("count", count.data(), {nz, ny, nx});
    w.set_attr("/", "format", "mlcg-grid");
    w.set_attr("/", "version", 1);
    w.set_attr("/", "time", time);
    w.set_attr("/", "index", e.index);
    w.set_attr("/", "origin_x", spec_.origin.x);
    w.set_attr("/", "origin_y", spec_.origin.y);
    w.set_attr("/", "origin_z", spec_.origin.z);
    w.set_attr("/", "h", spec_.h);
    w.set_attr("/", "nx", spec_.nx);
    w.set_attr("/", "ny", spec_.ny);
    w.set_attr("/", "nz", spec_.nz);
    w.commit();
  }
  append(e);
}

void GridSeries::header_to_json(json& j) const {
  j["grid"] = {{"origin", {spec_.origin.x, spec_.origin.y, spec_.origin.z}},
               {"h", spec_.h},
               {"dims", {spec_.nx, spec_.ny, spec_.nz}}};
}

void GridSeries::to_json(json& j, const Entry& e) const { j = {{"index", e.index}, {"time", e.time}}; }

GridSeries::Entry GridSeries::from_json(const json& j) const {
  return {j.at("index").get<std::uint64_t>(), j.at("time").get<double>()};
}

std::string GridSeries::xdmf_grid(const Entry&, const std::string& file) const {
  const std::string cells = std::to_string(spec_.nz) + " " + std::to_string(spec_.ny) + " " + std::to_string(spec_.nx);
  const std::string nodes =
      std::to_string(spec_.nz + 1) + " " + std::to_string(spec_.ny + 1) + " " + std::to_string(spec_.nx + 1);
  const std::string h = detail::format_double(spec_.h);
  // ORIGIN_DXDYDZ values are listed z y x, matching the Dimensions order.
  const std::string origin = detail::format_double(spec_.origin.z) + " " + detail::format_double(spec_.origin.y) +
                             " " + detail::format_double(spec_.origin.x);
  std::string g;
  g += "        <Topology TopologyType=\"3DCoRectMesh\" Dimensions=\"" + nodes + "\"/>\n";
  g += "        <Geometry GeometryType=\"ORIGIN_DXDYDZ\">\n";
  g += "          <DataItem Name=\"Origin\" Dimensions=\"3\" NumberType=\"Float\" Precision=\"8\" Format=\"XML\">" +
       origin + "</DataItem>\n";
  g += "          <DataItem Name=\"Spacing\" Dimensions=\"3\" NumberType=\"Float\" Precision=\"8\" Format=\"XML\">" +
       h + " " + h + " " + h + "</DataItem>\n";
  g += "        </Geometry>\n";
  const auto attribute = [&](const char* aname, const char* type, const std::string& dims) {
    g += std::string("        <Attribute Name=\"") + aname + "\" AttributeType=\"" + type + "\" Center=\"Cell\">\n";
    g += "          <DataItem Dimensions=\"" + dims + "\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">" +
         file + aname + "</DataItem>\n";
    g += "        </Attribute>\n";
  };
  attribute("volume_fraction", "Scalar", cells);
  attribute("mean_velocity", "Vector", cells + " 3");
  attribute("max_speed", "Scalar", cells);
  attribute("stress", "Tensor6", cells + " 6");
  attribute("count", "Scalar", cells);
  return g;
}

}  // namespace mlcg::io
