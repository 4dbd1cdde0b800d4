// coupler_service: the central coupler of a multi-level case. Started by
// `mlcg run` before the levels; binds one endpoint, registers every level of
// the case and runs the coupling intervals until they finish.
#include <csignal>
#include <cstdio>
#include <exception>

#include <CLI/CLI.hpp>
#include <spdlog/sinks/basic_file_sink.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include "bus/case_hash.hpp"
#include "bus/checkpoint_file.hpp"
#include "config/case_parser.hpp"
#include "core/heap.hpp"
#include "from_case.hpp"
#include "io/atomic_file.hpp"
#include "service.hpp"

namespace {
extern "C" void on_stop(int) { mlcg::coupling::requests().stop.store(true); }
extern "C" void on_abort(int) { mlcg::coupling::requests().abort.store(true); }
extern "C" void on_checkpoint(int) { mlcg::coupling::requests().checkpoint.store(true); }

std::shared_ptr<const mlcg::bus::CouplerCheckpoint> read_resume(const std::string& path, const std::string& hash) {
  std::shared_ptr<mlcg::bus::CouplerCheckpoint> c;
  try {
    c = std::make_shared<mlcg::bus::CouplerCheckpoint>(mlcg::bus::read_coupler_checkpoint(path));
  } catch (const std::exception& e) {
    throw std::runtime_error(std::string("--resume: ") + e.what() + "; resume from an intact consistent checkpoint");
  }
  if (c->case_hash() != hash)
    throw std::runtime_error("--resume " + path + ": written for another case (hash " + c->case_hash() +
                             ", this case's is " + hash + "); the case file changed since the checkpoint");
  return c;
}
}  // namespace

int main(int argc, char** argv) {
  mlcg::keep_freed_memory();
  CLI::App app{"coupler_service: the MLCG coupler of a multi-level case"};
  std::string case_file, out_dir, endpoint;
  uint64_t max_intervals = UINT64_MAX;
  bool quiet = false;
  app.add_option("case", case_file, "case file (TOML) with a [coupling] section")->required();
  app.add_option("--out", out_dir, "run folder (logs go to <out>/coupling and <out>/coupler.log)")->required();
  app.add_option("--endpoint", endpoint, "ZeroMQ endpoint to bind (default: the case's, else ipc://<out>/bus.ipc)");
  app.add_option("--max-intervals", max_intervals, "stop the levels after this many coupling intervals");
  app.add_flag("--quiet", quiet, "log to the file only");
  std::string curve_key, curve_clients, endpoint_file;  // CURVE on the bus (bus/curve.hpp)
  app.add_option("--curve-server-key", curve_key, "CURVE: this coupler's keypair file (with --curve-clients)");
  app.add_option("--curve-clients", curve_clients, "CURVE: the client public keys to accept (NAME KEY lines)");
  app.add_option("--endpoint-file", endpoint_file, "write the endpoint actually bound here (tcp://HOST:* picks a port)");
  std::string resume;
  app.add_option("--resume", resume, "continue from this coupler checkpoint (checkpoints/i<k>/coupler.pb)");
  CLI11_PARSE(app, argc, argv);

  try {
    std::filesystem::create_directories(out_dir);
    std::vector<spdlog::sink_ptr> sinks{
        std::make_shared<spdlog::sinks::basic_file_sink_mt>((std::filesystem::path(out_dir) / "coupler.log").string())};
    if (!quiet) sinks.push_back(std::make_shared<spdlog::sinks::stderr_color_sink_mt>());
    auto log = std::make_shared<spdlog::logger>("coupler", sinks.begin(), sinks.end());
    log->flush_on(spdlog::level::info);

    const auto cs = mlcg::config::load_case(case_file);
    auto cc = mlcg::coupling::coupling_from_case(cs);
    mlcg::coupling::Coupler coupler(cc.cfg, cc.fits, cc.pose);
    for (size_t r = 0; r < cc.cfg.regions.size(); ++r) {
      const auto& g = coupler.geometry(r);
      log->info("region {}: {} x {} x {} cells of {} m, {} inside the geometry, {} boundary faces at z = {} m", r,
                g.grid().nx(), g.grid().ny(), g.grid().nz(), g.cell_size(), g.cells(), g.faces(), g.top());
    }
    if (endpoint.empty()) endpoint = cs.coupling->endpoint;
    if (endpoint.empty()) endpoint = "ipc://" + (std::filesystem::absolute(out_dir) / "bus.ipc").string();
    zmq::context_t ctx;
    const auto curve = mlcg::bus::curve::server_from_files(
        ctx, curve_key, curve_clients, [log](const std::string& s) { log->warn("{}", s); },
        [log](const std::string& s) { log->info("{}", s); });
    mlcg::bus::Channel channel(ctx, mlcg::bus::Channel::Role::Router, endpoint, {}, mlcg::bus::kDefaultMaxBytes,
                               curve ? &curve->keys : nullptr);
    if (curve) curve->auth->watch(channel.socket());
    if (!endpoint_file.empty()) mlcg::io::write_file_atomic(endpoint_file, channel.endpoint() + "\n");
    mlcg::coupling::ServiceOptions opt;
    opt.case_hash = mlcg::bus::case_hash_of_bytes(mlcg::config::resolved_case_text(case_file));
    opt.out_dir = out_dir;
    opt.max_intervals = max_intervals;
    opt.checkpoint_every = mlcg::coupling::checkpoint_intervals(cs);
    opt.end_time = cs.time.end;
    if (!resume.empty()) opt.resume = read_resume(resume, opt.case_hash);
    // Ctrl-C: a consistent checkpoint, then every level stops; SIGTERM: stop now; SIGUSR1: checkpoint.
    std::signal(SIGINT, on_stop);
    std::signal(SIGTERM, on_abort);
    std::signal(SIGUSR1, on_checkpoint);
    mlcg::coupling::Service service(coupler, channel, opt, log);
    return service.run();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "coupler_service: error: %s\n", e.what());
    return 1;
  }
}
