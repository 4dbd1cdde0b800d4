#include "run/control.hpp"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "run/checkpoints.hpp"
#include "config/case_parser.hpp"
#include "io/atomic_file.hpp"

namespace fs = std::filesystem;

namespace mlcg::launcher {
namespace {
// The launcher still runs: its pid exists and is no zombie (a parent that has not reaped it yet, e.g. a
// script blocked on this very command, keeps the pid of a launcher that has ended), and its status.json
// does not say it ended.
bool launcher_alive(pid_t pid, const fs::path& run_dir) {
  if (kill(pid, 0) != 0) return false;
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string text((std::istreambuf_iterator<char>(stat)), std::istreambuf_iterator<char>());
  const auto paren = text.rfind(')');  // the state follows the command name, which may hold spaces
  if (paren != std::string::npos && paren + 2 < text.size() && text[paren + 2] == 'Z') return false;
  const auto st = read_json_or_null(run_dir / "status.json");
  const std::string state = st.is_object() ? st.value("state", "") : "";
  return state != "completed" && state != "interrupted" && state != "failed";
}
}  // namespace

int swap_command(const fs::path& run_dir, const std::string& level, const std::string& binary) {
  try {
    const RunInfo info = read_run_info(run_dir);
    const auto cs = config::load_case(info.case_file);
    if (std::none_of(cs.levels.begin(), cs.levels.end(), [&](const auto& l) { return l.name == level; }))
      throw std::runtime_error("--level " + level + ": the case " + info.case_file + " has no such level");
    const fs::path bin = fs::absolute(binary);
    if (!fs::is_regular_file(bin) || access(bin.c_str(), X_OK) != 0)
      throw std::runtime_error("--binary " + binary + ": not an executable file");
    const auto st = read_json_or_null(run_dir / "status.json");
    const pid_t launcher = st.is_object() ? st.value("launcher_pid", -1) : -1;
    if (!st.is_object() || launcher <= 0 || !launcher_alive(launcher, run_dir)) {
      const std::string state = st.is_object() ? st.value("state", "?") : std::string("missing");
      const bool ended = state == "completed" || state == "interrupted" || state == "failed";
      throw std::runtime_error(run_dir.string() + " is not running (status.json: " + state +
                               (launcher > 0 && !ended ? "; its launcher (pid " + std::to_string(launcher) +
                                                             ") has ended"
                                                       : std::string()) +
                               ")");
    }
    const std::string id = "swap-" + std::to_string(getpid()) + "-" +
                           std::to_string(std::chrono::system_clock::now().time_since_epoch().count());
    nlohmann::json j{{"level", level}, {"binary", bin.string()}};
    io::write_file_atomic(run_dir / "control" / (id + ".json"), j.dump() + "\n");
    std::printf("mlcg: asked the launcher (pid %d) to swap level '%s' to %s at the next checkpoint\n", launcher,
                level.c_str(), bin.c_str());
    std::fflush(stdout);
    const fs::path result = run_dir / "control" / (id + ".result.json");
    for (;;) {  // until the launcher answers or is gone
      const auto r = read_json_or_null(result);
      if (r.is_object()) {
        std::printf("mlcg: %s\n", r.value("message", "").c_str());
        fs::remove(result);
        return r.value("done", false) ? 0 : 1;
      }
      if (!launcher_alive(launcher, run_dir)) {
        // It may have answered just before it ended.
        const auto last = read_json_or_null(result);
        if (last.is_object()) continue;
        throw std::runtime_error("the launcher (pid " + std::to_string(launcher) + ") ended before swapping");
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: mlcg swap: %s\n", e.what());
    return 1;
  }
}

std::optional<SwapRequest> take_swap_request(const fs::path& run_dir) {
  std::vector<fs::path> files;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(run_dir / "control", ec)) {
    const std::string n = e.path().filename().string();
    if (n.rfind("swap-", 0) == 0 && e.path().extension() == ".json" && n.find(".result.") == std::string::npos &&
        n.find(".tmp.") == std::string::npos)
      files.push_back(e.path());
  }
  if (files.empty()) return std::nullopt;
  std::sort(files.begin(), files.end());
  const auto j = read_json_or_null(files.front());
  fs::remove(files.front(), ec);
  SwapRequest r;
  r.id = files.front().stem().string();
  if (!j.is_object()) return r;  // unreadable: answered as refused by the caller
  r.level = j.value("level", "");
  r.binary = j.value("binary", "");
  return r;
}

void write_swap_result(const fs::path& run_dir, const SwapRequest& r, bool done, const std::string& message) {
  if (r.id.empty()) return;  // from the case's [[swap]]: nobody waits
  nlohmann::json j{{"done", done}, {"message", message}};
  io::write_file_atomic(run_dir / "control" / (r.id + ".result.json"), j.dump() + "\n");
}

}  // namespace mlcg::launcher
