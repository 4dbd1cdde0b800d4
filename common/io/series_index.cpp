#include "io/series_index.hpp"

#include <nlohmann/json.hpp>

#include <charconv>
#include <cstdio>
#include <fstream>
#include <stdexcept>

#include "io/atomic_file.hpp"

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

SeriesIndexBase::SeriesIndexBase(const SeriesKind& kind, const fs::path& parent, std::string name)
    : kind_(kind), name_(std::move(name)) {
  detail::check_series_name(name_, kind_.who);
  dir_ = parent / name_;
  xmf_ = parent / (name_ + ".xmf");
  index_ = dir_ / "index.json";
  times_ = dir_ / "times.csv";
}

bool SeriesIndexBase::open(bool resume, const std::function<void(const json&)>& read_header) {
  const std::string who = kind_.who;
  std::error_code ec;
  fs::create_directories(dir_, ec);
  if (ec) throw std::runtime_error(who + ": cannot create '" + dir_.string() + "': " + ec.message());
  remove_stale_temps(dir_, name_ + "_");
  remove_stale_temps(dir_, "index.json");
  if (kind_.times_csv) remove_stale_temps(dir_, "times.csv");
  remove_stale_temps(xmf_.parent_path(), name_ + ".xmf");

  if (!fs::exists(index_)) return false;
  if (!resume)
    throw std::runtime_error(who + ": '" + index_.string() +
                             "' already exists; resume the series or use a fresh run directory");
  try {
    std::ifstream in(index_);
    if (!in) throw std::runtime_error("cannot read it");
    const json j = json::parse(in);
    if (j.at("format") != kind_.format || j.at(kind_.name_key) != name_)
      throw std::runtime_error(std::string("not a ") + kind_.noun + " named '" + name_ + "'");
    if (read_header) read_header(j);
    for (const json& e : j.at("entries")) append_from_json(e);
  } catch (const std::exception& e) {
    throw std::runtime_error(who + ": bad index '" + index_.string() + "': " + e.what());
  }
  return true;
}

void SeriesIndexBase::rebuild() {
  if (size() > 0) save_derived();
}

void SeriesIndexBase::truncate_after(double time) {
  std::size_t k = 0;
  while (k < size() && time_at(k) <= time) ++k;
  drop_from(k);
}

std::uint64_t SeriesIndexBase::start_entry(double time) {
  std::size_t k = 0;
  while (k < size() && time_at(k) < time) ++k;
  drop_from(k);
  return size() == 0 ? 0 : index_at(size() - 1) + 1;
}

void SeriesIndexBase::save() {
  save_index();
  save_derived();
}

fs::path SeriesIndexBase::data_file(std::uint64_t index) const {
  return dir_ / detail::numbered_name(name_, index, ".h5");
}

void SeriesIndexBase::drop_from(std::size_t k) {
  if (k >= size()) return;
  std::vector<std::uint64_t> dropped;
  for (std::size_t i = k; i < size(); ++i) dropped.push_back(index_at(i));
  keep_first(k);
  // Unlist first, delete after: a crash in between only leaves orphan files.
  save();
  std::error_code ec;
  for (std::uint64_t i : dropped) fs::remove(data_file(i), ec);
}

void SeriesIndexBase::save_index() const {
  json arr = json::array();
  for (std::size_t k = 0; k < size(); ++k) entry_to_json(arr.emplace_back(), k);
  json j = {{"format", kind_.format}, {"version", 1}, {kind_.name_key, name_}, {"entries", arr}};
  header_to_json(j);
  write_file_atomic(index_, j.dump(1) + "\n");
}

void SeriesIndexBase::save_derived() const {
  if (kind_.times_csv) {
    std::string s = "index,time\n";
    for (std::size_t k = 0; k < size(); ++k)
      s += std::to_string(index_at(k)) + "," + detail::format_double(time_at(k)) + "\n";
    write_file_atomic(times_, s);
  }
  std::error_code ec;
  if (size() == 0) {
    fs::remove(xmf_, ec);
    return;
  }
  std::string g;
  for (std::size_t k = 0; k < size(); ++k) {
    const std::string grid = detail::numbered_name(name_, index_at(k), "");
    g += "      <Grid Name=\"" + grid + "\" GridType=\"Uniform\">\n";
    g += "        <Time Value=\"" + detail::format_double(time_at(k)) + "\"/>\n";
    g += entry_xdmf(k, name_ + "/" + grid + ".h5:/");
    g += "      </Grid>\n";
  }
  write_file_atomic(xmf_, detail::xdmf_document(name_, g));
}

}  // namespace mlcg::io
