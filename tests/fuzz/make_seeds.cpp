// fuzz_seeds OUT_DIR: the seed corpora that cannot be copied from the source tree, made by the real
// writers from the shipped quickstart cases: OUT_DIR/<target>/ for bus_level, bus_coupler,
// coupler_checkpoint, manifest, hostfile, level_checkpoint and initial (HDF5 files as their content,
// fuzz_support.hpp). scripts/fuzz.sh calls it.
#include <hdf5.h>

#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <utility>
#include <exception>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "bus/channel.hpp"
#include "fuzz_support.hpp"
#include "io/snapshot_series.hpp"
#include "level/level.hpp"

namespace fs = std::filesystem;
using namespace mlcg;

namespace {

void seed(const fs::path& dir, const std::string& name, const std::string& bytes) {
  fs::create_directories(dir);
  fuzz::write_file(dir / name, bytes);
}

// The coupler's messages (bus_level), the levels' (bus_coupler) and the coupler's checkpoints.
void coupling_seeds(const fs::path& out) {
  const auto c = fuzz::quickstart_coupler().make();
  const auto& levels = c->config().levels;
  std::vector<bus::IntervalCommands> cmds = c->initial_commands();
  for (uint64_t k = 0; k < 4; ++k) {
    const auto stats = fuzz::plausible_stats(*c, k);
    for (size_t l = 0; l < levels.size(); ++l) {
      bus::Envelope e;
      *e.mutable_stats() = stats[l];
      if (k == 0 || k == 3)
        seed(out / "bus_coupler", "stats_" + levels[l].name + std::to_string(k), bus::encode(e, levels[l].name));
      e.Clear();
      *e.mutable_commands() = cmds[l];
      seed(out / "bus_level", "commands_" + levels[l].name + std::to_string(k), bus::encode(e, "coupler"));
    }
    cmds = c->advance(k, stats);
    bus::CouplerCheckpoint cp;
    cp.set_interval(k + 1);
    cp.set_sim_time(static_cast<double>(k + 1) * c->config().interval);
    cp.set_case_hash("0123456789abcdef");
    c->save(cp);
    for (const auto& cmd : cmds) *cp.add_commands() = cmd;
    seed(out / "coupler_checkpoint", "i" + std::to_string(k + 1) + ".pb", cp.SerializeAsString());
  }
  for (size_t l = 0; l < levels.size(); ++l) {
    bus::Envelope e;
    *e.mutable_welcome() = c->welcome(l, 0);
    seed(out / "bus_level", "welcome_" + levels[l].name, bus::encode(e, "coupler"));
    e.Clear();
    auto& r = *e.mutable_register_level();
    r.set_level_name(levels[l].name);
    r.set_alpha(levels[l].alpha);
    r.set_dt(levels[l].dt);
    r.set_ranks(1);
    r.set_case_hash("0123456789abcdef");
    seed(out / "bus_coupler", "register_" + levels[l].name, bus::encode(e, levels[l].name));
  }
  bus::Envelope hb;
  hb.mutable_heartbeat()->set_waiting_for("'fine'");
  seed(out / "bus_level", "heartbeat", bus::encode(hb, "coupler"));
  bus::Envelope bye;
  bye.mutable_bye()->set_reason("finished after interval 3");
  seed(out / "bus_coupler", "bye", bus::encode(bye, "fine"));
}

// Manifests as Service::write_checkpoint writes them (with and without a previous set).
void manifest_seeds(const fs::path& out) {
  nlohmann::json m;
  m["format"] = "mlcg-hierarchy-checkpoint";
  m["interval"] = 2;
  m["sim_time"] = 0.000192;
  m["case_hash"] = "0123456789abcdef";
  m["levels"] = {{"coarse", "i2/coarse.h5"}, {"fine", "i2/fine.h5"}};
  m["coupler"] = "i2/coupler.pb";
  seed(out / "manifest", "manifest", m.dump(2) + "\n");
  nlohmann::json previous = m;
  previous.erase("format");
  previous["interval"] = 1;
  previous["levels"] = {{"coarse", "i1/coarse.h5"}, {"fine", "i1/fine.h5"}};
  previous["coupler"] = "i1/coupler.pb";
  m["previous"] = previous;
  seed(out / "manifest", "manifest_previous", m.dump(2) + "\n");
  seed(out / "manifest", "launcher", nlohmann::json{{"case", "/work/cases/quickstart/mlcg.toml"}}.dump(2) + "\n");
}

// The README's hostfile and the tests' (test_hosts, test_netns).
void hostfile_seeds(const fs::path& out) {
  seed(out / "hostfile", "readme",
       "# hosts of a two-level run\n"
       "rsh_agent /bin/true            # optional: mpirun's --mca plm_rsh_agent\n"
       "mca oob_tcp_if_include 10.77.0.0/24\n"
       "h1 slots=1 coupler address=127.0.0.1\n"
       "h2 slots=2 levels=coarse\n"
       "h3 slots=4 levels=fine,finest\n");
  seed(out / "hostfile", "netns",
       "mlcg-h1 slots=1 coupler\nmlcg-h2 slots=1 levels=coarse\nmlcg-h3 slots=1 levels=fine\n");
  seed(out / "hostfile", "local", "localhost slots=4\n");
}

// ---- HDF5 files as content (fuzz_support.hpp) -----------------------------------------------------

struct Content {
  hid_t file;
  std::string out;
};

std::string read_raw(hid_t obj, hid_t mem_type, size_t bytes, bool attribute) {
  std::string b(bytes, '\0');
  if (bytes > 0 && (attribute ? H5Aread(obj, mem_type, b.data()) : H5Dread(obj, mem_type, H5S_ALL, H5S_ALL,
                                                                           H5P_DEFAULT, b.data())) < 0)
    throw std::runtime_error("fuzz_seeds: cannot read an HDF5 object");
  return b;
}

// The H5Type of a stored type and the native type to read it as.
std::pair<fuzz::H5Type, hid_t> type_of(hid_t type) {
  const bool is_signed = H5Tget_sign(type) != H5T_SGN_NONE;
  switch (H5Tget_class(type)) {
    case H5T_FLOAT: return {fuzz::H5Type::F64, H5T_NATIVE_DOUBLE};
    case H5T_STRING: return {fuzz::H5Type::String, type};
    default:
      if (H5Tget_size(type) == 1) return {fuzz::H5Type::U8, H5T_NATIVE_UINT8};
      if (H5Tget_size(type) == 4) return {fuzz::H5Type::I32, H5T_NATIVE_INT32};
      return is_signed ? std::pair{fuzz::H5Type::I64, H5T_NATIVE_INT64} : std::pair{fuzz::H5Type::U64, H5T_NATIVE_UINT64};
  }
}

herr_t add_attribute(hid_t obj, const char* name, const H5A_info_t*, void* data) {
  auto& c = *static_cast<std::pair<Content*, std::string>*>(data);
  const hid_t a = H5Aopen(obj, name, H5P_DEFAULT), type = H5Aget_type(a);
  const auto [t, mem] = type_of(type);
  const size_t bytes = t == fuzz::H5Type::String ? H5Tget_size(type) : 8;
  std::string b = read_raw(a, mem, bytes, true);
  if (t == fuzz::H5Type::String) b.resize(std::strlen(b.c_str()));
  fuzz::append_h5_entry(c.first->out, fuzz::H5Kind::Attribute, t, 0, c.second + "@" + name, b);
  H5Tclose(type);
  H5Aclose(a);
  return 0;
}

void add_object(Content& c, const std::string& path) {
  const hid_t obj = H5Oopen(c.file, path.c_str(), H5P_DEFAULT);
  if (H5Iget_type(obj) == H5I_DATASET) {
    const hid_t type = H5Dget_type(obj), space = H5Dget_space(obj);
    const auto [t, mem] = type_of(type);
    hsize_t dims[2] = {0, 1};
    const int rank = H5Sget_simple_extent_dims(space, dims, nullptr);
    const size_t n = static_cast<size_t>(H5Sget_simple_extent_npoints(space));
    fuzz::append_h5_entry(c.out, fuzz::H5Kind::Dataset, t, rank == 2 ? static_cast<uint8_t>(dims[1]) : 0, path,
                          read_raw(obj, mem, n * H5Tget_size(mem), false));
    H5Sclose(space);
    H5Tclose(type);
  } else {
    if (path != "/") fuzz::append_h5_entry(c.out, fuzz::H5Kind::Group, fuzz::H5Type::U8, 0, path, {});
    H5G_info_t info;
    H5Gget_info(obj, &info);
    for (hsize_t i = 0; i < info.nlinks; ++i) {
      char name[256];
      H5Lget_name_by_idx(obj, ".", H5_INDEX_NAME, H5_ITER_INC, i, name, sizeof name, H5P_DEFAULT);
      add_object(c, (path == "/" ? "" : path + "/") + name);
    }
  }
  std::pair<Content*, std::string> at{&c, path};
  H5Aiterate2(obj, H5_INDEX_NAME, H5_ITER_INC, nullptr, add_attribute, &at);
  H5Oclose(obj);
}

// Every group, dataset and attribute of an HDF5 file, as content.
std::string h5_content(const fs::path& file) {
  Content c{H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), {}};
  if (c.file < 0) throw std::runtime_error("fuzz_seeds: cannot open " + file.string());
  add_object(c, "/");
  H5Fclose(c.file);
  return c.out;
}

// A seed the reader refuses would exercise only the refusal: each must restart (or start, as the [initial]
// file) the quickstart hopper and run a step.
void check_accepted(config::CaseSpec cs, const std::string& content, bool restart) {
  const fs::path file = fuzz::scratch() / "accepted.h5";
  fuzz::write_h5_content(file, reinterpret_cast<const uint8_t*>(content.data()), content.size());
  LevelOptions opt;
  opt.quiet = true;
  opt.single_rank = true;
  if (restart) opt.restart = file;
  else cs.initial = config::InitialSpec{file.string(), "beads", {cs.path, 1}};
  Level level(cs, opt);
  level.step_once();
}

// Checkpoints and snapshots of the quickstart hopper while it fills, as content.
void level_seeds(const fs::path& out) {
  const auto cs = fuzz::shipped_case("cases/quickstart/case.toml");
  LevelOptions opt;
  opt.quiet = true;
  opt.single_rank = true;
  Level level(cs, opt);
  const fs::path run = fuzz::scratch("seed_run");
  io::SnapshotSeries snapshots(run, "particles");
  for (int stage = 1; stage <= 2; ++stage) {
    for (int s = 0; s < 400; ++s) level.step_once();
    const fs::path checkpoint = run / ("checkpoint" + std::to_string(stage) + ".h5");
    level.write_checkpoint(checkpoint);
    const std::string content = h5_content(checkpoint);
    check_accepted(cs, content, true);
    seed(out / "level_checkpoint", "quickstart" + std::to_string(stage), content);
    const Particles& p = level.particles();
    snapshots.write(level.time(), level.step(), p.n_local(), p.x.data(), p.v.data(), p.omega.data(), p.radius.data(),
                    p.id.data());
  }
  for (const auto& e : fs::recursive_directory_iterator(run))
    if (e.path().extension() == ".h5" && e.path().parent_path() != run) {
      const std::string content = h5_content(e.path());
      check_accepted(cs, content, false);
      seed(out / "initial", e.path().stem().string(), content);
    }
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: fuzz_seeds OUT_DIR\n");
    return 2;
  }
  try {
    const fs::path out = argv[1];
    coupling_seeds(out);
    manifest_seeds(out);
    hostfile_seeds(out);
    level_seeds(out);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fuzz_seeds: %s\n", e.what());
    return 1;
  }
  return 0;
}
