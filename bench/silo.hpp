#pragma once
// The silo scenes (bed, discharge): the settled bed prepared once (or reused), every scene x rank count x
// code run in rounds of repeats, one table per scene, and the ours/LIGGGHTS ratio of the bed.
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "scenes.hpp"

namespace mlcg::bench {

struct SiloOptions {
  std::vector<Scene> scenes;
  std::vector<int> ranks;
  int repeat = 1;
  bool rebuild_bed = false;
  std::filesystem::path dem_level, work;
  std::optional<std::filesystem::path> mpirun;    // none: no runs on more than one rank
  std::optional<std::filesystem::path> liggghts;  // none: ours only
  bool liggghts_installed = false;                // installed (even when skipped)
};

// The silo and lid as STL in DIR/geometry: both codes read these files, the silo scenes and the pour.
Files write_silo_files(const BenchParams& p, const std::filesystem::path& work);

// Runs the scenes and prints their tables. Returns the machine-readable line:
// "ratio_vs_liggghts rank1=<x> rank2=<y>" or "liggghts=absent".
std::string run_silo_scenes(const BenchParams& p, const Files& files, const SiloOptions& o);

}  // namespace mlcg::bench
