#include "parse.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <regex>
#include <sstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "process.hpp"

namespace mlcg::bench {

namespace fs = std::filesystem;

namespace {

std::string slurp(const fs::path& f) {
  std::ifstream in(f);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::string trim(std::string s) {
  const auto b = s.find_first_not_of(" \t\r\n");
  if (b == std::string::npos) return "";
  const auto e = s.find_last_not_of(" \t\r\n");
  return s.substr(b, e - b + 1);
}

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream ss(text);
  std::string l;
  while (std::getline(ss, l)) out.push_back(l);
  return out;
}

// The error message a failed process printed: its first "ERROR"/"error:" line, else a crash's
// "Signal:" line, else its last line.
std::string error_of(const fs::path& console_log, int exit_code) {
  std::string last, signal;
  for (const auto& raw : lines_of(slurp(console_log))) {
    const std::string l = trim(raw);
    if (l.empty() || l[0] == '$' || l.rfind("[exit code", 0) == 0) continue;
    if (l.find("ERROR") != std::string::npos || l.find("error:") != std::string::npos) return l;
    if (signal.empty() && l.find("Signal:") != std::string::npos) signal = l;
    last = l;
  }
  if (!signal.empty()) return signal;
  return last.empty() ? fmt::format("exit code {}", exit_code) : fmt::format("{} (exit code {})", last, exit_code);
}

}  // namespace

double median(std::vector<double> v) {
  v.erase(std::remove_if(v.begin(), v.end(), [](double x) { return std::isnan(x); }), v.end());
  if (v.empty()) return kNaN;
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

std::string first_line_with(const fs::path& file, const std::string& needle) {
  for (const auto& l : lines_of(slurp(file)))
    if (l.find(needle) != std::string::npos) return trim(l);
  return "";
}

RunMetrics parse_mlcg(const fs::path& run_dir, const fs::path& console_log, int exit_code, Count count) {
  RunMetrics m;
  const fs::path summary = run_dir / "summary.json";
  if (exit_code != 0 || !fs::exists(summary)) {
    m.error = error_of(console_log, exit_code);
    return m;
  }
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(slurp(summary));
    const auto& lv = j.at("levels").at(0);
    const auto& perf = lv.at("performance");
    const auto& sec = perf.at("seconds");
    auto num = [](const nlohmann::json& o, const char* k) { return o.contains(k) ? o.at(k).get<double>() : 0.0; };
    m.ranks = lv.value("ranks", 1);
    m.steps = j.at("steps").get<long>();
    m.particles = lv.value("particles_max", 0L);
    m.particles_end = lv.value("particles_final", 0L);
    const double wall = j.at("wall_seconds").get<double>();
    const double output = num(sec, "output");
    m.loop_seconds = wall - output;
    const double ps = lv.at("particle_steps").get<double>();
    m.rate = m.loop_seconds > 0 ? ps / m.loop_seconds : 0.0;
    // Guard against a per-rank particle count (all ranks must be counted): compare with particles x steps.
    const double expect = static_cast<double>(m.particles) * static_cast<double>(m.steps);
    if (count == Count::Constant && m.ranks > 1 && expect > 0 && ps < 0.95 * expect &&
        m.particles_end >= 0.99 * m.particles) {
      m.warnings.push_back(fmt::format("summary.json particle_steps = {:.4g} < particles x steps = {:.4g} (per-rank "
                                       "count?); the rate uses particles x steps",
                                       ps, expect));
      m.rate = expect / m.loop_seconds;
    }
    m.neighbours = perf.value("neighbour_pairs_per_particle", kNaN);
    m.rebuilds_per_1000 = perf.value("rebuilds_per_1000_steps", kNaN);
    m.bytes_per_particle = perf.value("bytes_per_particle", kNaN);
    const double f = num(sec, "force"), nb = num(sec, "neighbor"), c = num(sec, "comm"), ms = num(sec, "measure");
    if (m.loop_seconds > 0) {
      m.share[0] = f / m.loop_seconds;
      m.share[1] = nb / m.loop_seconds;
      m.share[2] = c / m.loop_seconds;
      m.share[3] = ms / m.loop_seconds;
      m.share[4] = std::max(0.0, m.loop_seconds - f - nb - c - ms) / m.loop_seconds;
      m.insert_share = num(sec, "insert") / m.loop_seconds;
    }
    const auto& mb = j.at("mass_balance");
    m.inserted = mb.at("inserted").get<long>();
    m.failed_to_place = mb.at("failed_to_place").get<long>();
    m.breakdown = fmt::format("wall {:.2f} s = force {:.2f} + neighbor {:.2f} + integrate {:.2f} + comm {:.2f} + "
                              "measure {:.2f} + insert {:.2f} + output {:.2f} + rest {:.2f}",
                              wall, f, nb, num(sec, "integrate"), c, ms, num(sec, "insert"), output,
                              wall - f - nb - num(sec, "integrate") - c - ms - num(sec, "insert") - output);
    const std::string status = j.value("status", "");
    if (status != "completed") m.warnings.push_back("summary.json status = '" + status + "'");
  } catch (const std::exception& e) {
    m.error = summary.string() + ": " + e.what();
    return m;
  }
  // Final kinetic energy: last row of series.csv.
  const auto rows = lines_of(slurp(run_dir / "series.csv"));
  if (rows.size() >= 2) {
    std::stringstream ss(rows.back());
    std::string t, n, ke;
    if (std::getline(ss, t, ',') && std::getline(ss, n, ',') && std::getline(ss, ke, ',')) {
      try {
        m.final_kinetic_energy = std::stod(ke);
      } catch (...) {
      }
    }
  }
  for (const auto& l : lines_of(slurp(run_dir / "log.txt")))
    if (l.find("warn") != std::string::npos || l.find("WARN") != std::string::npos) m.warnings.push_back(trim(l));
  m.ok = true;
  return m;
}

RunMetrics run_mlcg(const fs::path& dem_level, const fs::path& mpirun, int ranks, const fs::path& case_file,
                    const fs::path& run_dir, Count count) {
  fs::remove_all(run_dir);
  fs::create_directories(run_dir);
  std::vector<std::string> cmd;
  if (ranks > 1) cmd = mpirun_prefix(mpirun, ranks);
  for (const auto& a : {dem_level.string(), case_file.string(), std::string("--out"), run_dir.string(),
                        std::string("--quiet")})
    cmd.push_back(a);
  const auto r = run_process(cmd, run_dir, run_dir / "console.txt");
  RunMetrics m = parse_mlcg(run_dir, run_dir / "console.txt", r.exit_code, count);
  if (r.background_cores() >= 0) m.background_cores = r.background_cores();
  return m;
}

RunMetrics parse_liggghts(const fs::path& log, const fs::path& console_log, int exit_code) {
  RunMetrics m;
  const std::string text = slurp(fs::exists(log) ? log : console_log);
  static const std::regex loop(R"(Loop time of ([-+0-9.eE]+) on (\d+) procs for (\d+) steps with (\d+) atoms)");
  static const std::regex tline(R"(^(\w+)\s+time \(%\) = ([-+0-9.eE]+) \(([-+0-9.eE]+)\))");
  static const std::regex neighs(R"(Ave neighs/atom = ([-+0-9.eE]+))");
  static const std::regex builds(R"(Neighbor list builds = (\d+))");
  static const std::regex dangerous(R"(Dangerous builds = (\d+))");
  static const std::regex memory(R"(Memory usage per processor = ([-+0-9.eE]+) Mbytes)");
  static const std::regex atoms_read(R"(^\s*(\d+) atoms\s*$)");
  static const std::regex thermo_row(R"(^\s*(\d+)\s+(\d+)\s+([-+0-9.eE]+)\s*$)");
  std::smatch s;
  bool have_loop = false;
  double pair = kNaN, neigh = kNaN, comm = kNaN;
  double accounted = 0.0;
  std::string breakdown;
  double mbytes = kNaN;
  for (const auto& raw : lines_of(text)) {
    const std::string l = trim(raw);
    if (std::regex_search(raw, s, loop)) {
      have_loop = true;
      m.loop_seconds = std::stod(s[1]);
      m.ranks = std::stoi(s[2]);
      m.steps = std::stol(s[3]);
      m.particles_end = std::stol(s[4]);
    } else if (std::regex_search(raw, s, tline)) {
      const std::string name = s[1];
      const double t = std::stod(s[2]);
      breakdown += fmt::format("{}{} {:.2f}", breakdown.empty() ? "" : " + ", name, t);
      if (name == "Pair") pair = t;
      else if (name == "Neigh") neigh = t;
      else if (name == "Comm") comm = t;
      accounted += t;
    } else if (std::regex_search(raw, s, neighs)) {
      m.neighbours = std::stod(s[1]);
    } else if (std::regex_search(raw, s, builds)) {
      m.rebuilds_per_1000 = std::stod(s[1]);  // scaled below
    } else if (std::regex_search(raw, s, dangerous)) {
      m.dangerous_builds = std::stol(s[1]);
    } else if (std::regex_search(raw, s, memory)) {
      mbytes = std::stod(s[1]);
    } else if (m.particles == 0 && std::regex_match(raw, s, atoms_read)) {
      m.particles = std::stol(s[1]);
    } else if (!have_loop && std::regex_match(raw, s, thermo_row)) {
      m.final_kinetic_energy = std::stod(s[3]);
    }
    if (l.rfind("WARNING", 0) == 0 &&
        std::find(m.warnings.begin(), m.warnings.end(), l) == m.warnings.end())
      m.warnings.push_back(l);
  }
  if (exit_code != 0 || !have_loop) {
    m.error = error_of(console_log, exit_code);
    if (fs::exists(log)) {
      const std::string e = first_line_with(log, "ERROR");
      if (!e.empty()) m.error = e;
    }
    return m;
  }
  m.rate = m.loop_seconds > 0 ? static_cast<double>(m.particles_end) * m.steps / m.loop_seconds : 0.0;
  // "Neighbor list builds" leaves out the build during setup; count it, as dem_level counts its first build.
  if (!std::isnan(m.rebuilds_per_1000) && m.steps > 0)
    m.rebuilds_per_1000 = (m.rebuilds_per_1000 + 1.0) * 1000.0 / static_cast<double>(m.steps);
  if (!std::isnan(mbytes) && m.particles_end > 0)
    m.bytes_per_particle = mbytes * 1048576.0 * m.ranks / static_cast<double>(m.particles_end);
  if (m.loop_seconds > 0) {
    m.share[0] = pair / m.loop_seconds;
    m.share[1] = neigh / m.loop_seconds;
    m.share[2] = comm / m.loop_seconds;
    m.share[4] = std::max(0.0, accounted - (std::isnan(pair) ? 0 : pair) - (std::isnan(neigh) ? 0 : neigh) -
                                   (std::isnan(comm) ? 0 : comm)) /
                 m.loop_seconds;
  }
  m.breakdown = fmt::format("loop {:.2f} s = {}", m.loop_seconds, breakdown);
  if (m.particles == 0) m.particles = m.particles_end;
  m.ok = true;
  return m;
}

const RunMetrics& median_run(const std::vector<RunMetrics>& runs) {
  const double rate = median_of(runs, [](const RunMetrics& m) { return m.rate; });
  const RunMetrics* mid = &runs.front();
  for (const auto& m : runs)
    if (std::abs(m.rate - rate) < std::abs(mid->rate - rate)) mid = &m;
  return *mid;
}

double rate_spread(const std::vector<RunMetrics>& runs) {
  if (runs.size() < 2) return kNaN;
  double lo = 1e300, hi = -1e300;
  for (const auto& m : runs) lo = std::min(lo, m.rate), hi = std::max(hi, m.rate);
  return (hi - lo) / median_of(runs, [](const RunMetrics& m) { return m.rate; });
}

std::string fmt_num(double x, const char* spec) {
  return std::isnan(x) ? "-" : fmt::format(fmt::runtime(spec), x);
}
std::string fmt_pct(double x) { return std::isnan(x) ? "-" : fmt::format("{:.1f}%", 100.0 * x); }

}  // namespace mlcg::bench
