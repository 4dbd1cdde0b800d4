#pragma once
// What the fuzz targets share: shipped cases to feed, a scratch folder for inputs that the readers
// under test take as files, and the plausible traffic of a two-level run (the coupler of a shipped
// case, statistics every level could send) against which one message or checkpoint is fuzzed.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "config/case_spec.hpp"
#include "coupler.hpp"
#include "from_case.hpp"
#include "mlcg/bus.pb.h"

namespace mlcg::fuzz {

// A file of the source tree (cases/..., tests/data/...).
std::filesystem::path source(const std::string& relative);

// This process's scratch folder (removed at exit); `sub` is created inside it.
std::filesystem::path scratch(const std::string& sub = "");

// Replaces `path` with the bytes of an input.
void write_file(const std::filesystem::path& path, const uint8_t* data, size_t size);
void write_file(const std::filesystem::path& path, std::string_view text);

// HDF5 content: the HDF5 targets fuzz what a file says (which datasets and attributes, their names, types,
// shapes and values), written by MLCG's own H5Writer, not libhdf5's decoding of damaged bytes (Debian's
// libhdf5 1.10.8 allocates and zeroes gigabytes for some damaged headers before it refuses the file, which
// no caller can prevent). Entries follow each other until the input ends:
//   u8 kind (H5Kind, modulo 3), u8 type (H5Type, modulo 6), u8 columns (a dataset of n x columns when above
//   1), u16 name length, name ("group/dataset", "group" or "object@attribute"), u32 byte count, the bytes.
// An entry cut short ends the content; one H5Writer refuses is left out.
enum class H5Kind : uint8_t { Dataset, Attribute, Group };
enum class H5Type : uint8_t { F64, I64, I32, U64, U8, String };
void write_h5_content(const std::filesystem::path& file, const uint8_t* data, size_t size);
void append_h5_entry(std::string& content, H5Kind kind, H5Type type, uint8_t columns, const std::string& name,
                     std::string_view bytes);

// Sets up a level of `cs` (continuing from `restart` when given) and runs two steps, as dem_level would;
// a std::runtime_error (the refusal of bad input) ends it quietly.
void run_level(const config::CaseSpec& cs, const std::filesystem::path& restart = {});

// A shipped case, parsed.
config::CaseSpec shipped_case(const std::string& relative);

// The coupler of a shipped multi-level case, as coupler_service builds it.
struct CouplerSetup {
  config::CaseSpec cs;
  coupling::CaseCoupling cc;
  std::unique_ptr<coupling::Coupler> make() const { return std::make_unique<coupling::Coupler>(cc.cfg, cc.fits); }
};
const CouplerSetup& quickstart_coupler();  // cases/quickstart/mlcg.toml

// Statistics of interval k every level of `c` could send: downward flow through every boundary face
// of every region, a settled bed in every cell, empty insertion slabs.
std::vector<bus::IntervalStats> plausible_stats(const coupling::Coupler& c, uint64_t k);

}  // namespace mlcg::fuzz
