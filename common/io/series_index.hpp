#pragma once
// Bookkeeping shared by SnapshotSeries and GridSeries. A series NAME in a
// folder PARENT is a list of entries (index, time, per-kind fields), each with
// a data file the owner writes, plus the files kept from the list:
//
//   PARENT/NAME/NAME_000042.h5   data file of entry 42 (written by the owner)
//   PARENT/NAME/index.json       the list itself (read back on resume)
//   PARENT/NAME/times.csv        index,time (only for kinds that ask for it)
//   PARENT/NAME.xmf              XDMF Temporal Collection, one grid per entry
//
// Every file is replaced atomically, index.json before the files derived from
// it, and data files are deleted only once unlisted: a crash at any point
// leaves an index that only lists complete files.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json_fwd.hpp>

namespace mlcg::io {

namespace detail {
// "base_000042.h5" (at least 6 digits).
std::string numbered_name(std::string_view base, std::uint64_t index, std::string_view ext);
// Shortest decimal text that parses back to exactly `v` (XML, CSV).
std::string format_double(double v);
// Series names become file names and XML attribute values: [A-Za-z0-9_.-]+, no leading '.'.
void check_series_name(const std::string& name, const char* who);
// Complete XDMF 3 document: one Temporal Collection `name` around `grids` (XML text).
std::string xdmf_document(const std::string& name, const std::string& grids);
}  // namespace detail

// What tells one kind of series from another, besides its entry type.
struct SeriesKind {
  const char* who;       // class name, starts error messages
  const char* noun;      // "snapshot series", for "not a ... named"
  const char* format;    // index.json "format"
  const char* name_key;  // index.json key holding the series name
  bool times_csv;        // also keep NAME/times.csv
};

// The fields every entry has (GridSeries needs no others).
struct SeriesEntry {
  std::uint64_t index = 0;  // file counter
  double time = 0.0;
};

// The part that does not depend on the entry type, compiled once; it sees
// the entries through the virtuals SeriesIndex<Entry> implements.
class SeriesIndexBase {
 public:
  virtual ~SeriesIndexBase() = default;

  // Drops entries with time > `time` (e.g. right after restarting from a checkpoint).
  void truncate_after(double time);

  virtual std::size_t size() const = 0;
  void set_compression(bool on) { compress_ = on; }
  const std::filesystem::path& xmf_path() const { return xmf_; }
  const std::filesystem::path& directory() const { return dir_; }

 protected:
  // Checks the name; touches no file yet, so the owner can validate first.
  SeriesIndexBase(const SeriesKind& kind, const std::filesystem::path& parent, std::string name);

  // Creates the folder and clears stale temps. If index.json exists: throws
  // unless `resume` (refuses to mix two runs), else reads it, passing the
  // document to `read_header` for the kind's own fields. Returns whether it did.
  bool open(bool resume, const std::function<void(const nlohmann::json&)>& read_header = nullptr);
  // After open(): a crash may have left times.csv and the xmf one entry behind.
  void rebuild();
  // Drops entries at times >= `time` (after a restart the re-run replaces what
  // was written past the checkpoint); returns the index of the next entry.
  std::uint64_t start_entry(double time);
  // Rewrites index.json, then the files derived from it.
  void save();

  std::filesystem::path data_file(std::uint64_t index) const;
  const std::string& name() const { return name_; }
  bool compression() const { return compress_; }

  // The kind's own index.json fields besides format, version, name and entries.
  virtual void header_to_json(nlohmann::json&) const {}

 private:
  void drop_from(std::size_t k);  // removes entries [k..] and their files
  void save_index() const;
  void save_derived() const;

  virtual std::uint64_t index_at(std::size_t k) const = 0;
  virtual double time_at(std::size_t k) const = 0;
  virtual void keep_first(std::size_t k) = 0;
  virtual void entry_to_json(nlohmann::json& j, std::size_t k) const = 0;
  virtual void append_from_json(const nlohmann::json& j) = 0;
  virtual std::string entry_xdmf(std::size_t k, const std::string& file) const = 0;

  SeriesKind kind_;
  std::string name_;
  std::filesystem::path dir_, xmf_, index_, times_;
  bool compress_ = false;
};

// Owns the entries; the owning series says how an entry reads in index.json
// and in the xmf.
template <class Entry>
class SeriesIndex : public SeriesIndexBase {
 public:
  const std::vector<Entry>& entries() const { return entries_; }
  std::size_t size() const final { return entries_.size(); }
  std::filesystem::path file_path(const Entry& e) const { return data_file(e.index); }

 protected:
  using SeriesIndexBase::SeriesIndexBase;

  // Lists `e` once its data file is complete.
  void append(const Entry& e) {
    entries_.push_back(e);
    save();
  }

  virtual void to_json(nlohmann::json& j, const Entry& e) const = 0;
  virtual Entry from_json(const nlohmann::json& j) const = 0;
  // The grid's Topology, Geometry and Attributes, reading datasets from `file`
  // ("NAME/NAME_000042.h5:/"); Grid and Time are written around it.
  virtual std::string xdmf_grid(const Entry& e, const std::string& file) const = 0;

 private:
  std::uint64_t index_at(std::size_t k) const final { return entries_[k].index; }
  double time_at(std::size_t k) const final { return entries_[k].time; }
  void keep_first(std::size_t k) final { entries_.resize(k); }
  void entry_to_json(nlohmann::json& j, std::size_t k) const final { to_json(j, entries_[k]); }
  void append_from_json(const nlohmann::json& j) final { entries_.push_back(from_json(j)); }
  std::string entry_xdmf(std::size_t k, const std::string& file) const final { return xdmf_grid(entries_[k], file); }

  std::vector<Entry> entries_;
};

}  // namespace mlcg::io
