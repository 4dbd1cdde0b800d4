#pragma once
// Thin RAII layer over the HDF5 C API for checkpoints and snapshots.
// hdf5.h stays out of this header; handles are HDF5's 64-bit hid_t.
// All failures throw std::runtime_error naming the file and object; HDF5's own
// error-stack printing is switched off.
#include <concepts>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "core/vec3.hpp"
#include "io/atomic_file.hpp"

namespace mlcg::io {

// Element types supported for datasets (stored little-endian, same width).
template <class T>
concept H5Element = std::same_as<T, double> || std::same_as<T, std::int64_t> ||
                    std::same_as<T, std::int32_t> || std::same_as<T, std::uint64_t> ||
                    std::same_as<T, std::uint8_t>;

// Builds a new HDF5 file in memory; commit() writes it under a temp name with
// plain system calls (a full disk is an exception naming the file) and renames
// it over `path`. Destroyed without commit(): nothing is written and any
// existing file at `path` is left untouched.
// Paths are "a/b/x" (leading '/' optional); missing parent groups are created.
class H5Writer {
 public:
  explicit H5Writer(std::filesystem::path path);
  ~H5Writer();
  H5Writer(const H5Writer&) = delete;
  H5Writer& operator=(const H5Writer&) = delete;
  H5Writer(H5Writer&& o) noexcept;
  H5Writer& operator=(H5Writer&&) = delete;

  // gzip (plus byte shuffle) for datasets of >= 4096 elements written after
  // this call; those are chunked. Off by default: snapshots favour speed.
  void set_compression(bool on, int level = 4);

  void create_group(const std::string& path);

  template <H5Element T>
  void write(const std::string& path, const T* data, std::size_t n);
  template <H5Element T>
  void write(const std::string& path, const std::vector<T>& v) { write(path, v.data(), v.size()); }
  // Row-major array of shape `dims` (product of dims elements at `data`).
  template <H5Element T>
  void write_shaped(const std::string& path, const T* data, const std::vector<std::uint64_t>& dims);
  // n x 3 double dataset.
  void write_vec3(const std::string& path, const Vec3* data, std::size_t n);
  void write_vec3(const std::string& path, const std::vector<Vec3>& v) { write_vec3(path, v.data(), v.size()); }

  // Scalar attribute on a group or dataset ("" or "/" = file root); replaces
  // an existing attribute of the same name. Signed integers are stored as
  // int64, unsigned as uint64, strings as fixed-length UTF-8.
  void set_attr(const std::string& obj, const std::string& name, double v);
  void set_attr(const std::string& obj, const std::string& name, std::string_view v);
  void set_attr(const std::string& obj, const std::string& name, const char* v) {
    set_attr(obj, name, std::string_view(v));
  }
  template <std::integral T>
  void set_attr(const std::string& obj, const std::string& name, T v) {
    if constexpr (std::is_signed_v<T>) set_attr_i64(obj, name, static_cast<std::int64_t>(v));
    else set_attr_u64(obj, name, static_cast<std::uint64_t>(v));
  }

  // Close, fsync and rename into place. Further writes throw.
  void commit();
  bool committed() const { return committed_; }
  const std::filesystem::path& path() const { return tmp_.final_path(); }

 private:
  void write_raw(const std::string& path, std::int64_t file_type, std::int64_t mem_type,
                 const void* data, const std::vector<std::uint64_t>& dims);
  void set_attr_raw(const std::string& obj, const std::string& name, std::int64_t file_type,
                    std::int64_t mem_type, const void* v);
  void set_attr_i64(const std::string& obj, const std::string& name, std::int64_t v);
  void set_attr_u64(const std::string& obj, const std::string& name, std::uint64_t v);
  void require_open(const std::string& what) const;
  std::string where(const std::string& obj) const;

  AtomicPath tmp_;
  std::int64_t file_ = -1;
  bool compress_ = false;
  int level_ = 4;
  bool committed_ = false;
};

// Read-only view of an HDF5 file. Dataset reads require the stored element
// type to match T exactly (class, width, signedness); any shape is accepted
// and returned flattened in row-major order.
class H5Reader {
 public:
  explicit H5Reader(std::filesystem::path path);
  ~H5Reader();
  H5Reader(const H5Reader&) = delete;
  H5Reader& operator=(const H5Reader&) = delete;
  H5Reader(H5Reader&& o) noexcept;
  H5Reader& operator=(H5Reader&&) = delete;

  bool has(const std::string& path) const;  // group or dataset
  bool has_attr(const std::string& obj, const std::string& name) const;
  std::vector<std::uint64_t> shape(const std::string& dataset) const;

  template <H5Element T>
  std::vector<T> read(const std::string& dataset) const;
  std::vector<Vec3> read_vec3(const std::string& dataset) const;  // needs shape (n, 3)

  double attr_double(const std::string& obj, const std::string& name) const;
  std::int64_t attr_int64(const std::string& obj, const std::string& name) const;
  std::uint64_t attr_uint64(const std::string& obj, const std::string& name) const;
  std::string attr_string(const std::string& obj, const std::string& name) const;

  const std::filesystem::path& path() const { return path_; }

 private:
  std::int64_t open_dataset(const std::string& dataset) const;
  std::int64_t open_attr(const std::string& obj, const std::string& name) const;
  void read_attr_number(const std::string& obj, const std::string& name, bool want_float,
                        int want_sign, std::int64_t mem_type, void* out) const;
  std::string where(const std::string& obj) const;
  // Refuses a dataset of `bytes` of data that the file cannot hold (a damaged size field).
  void check_stored(std::int64_t ds, const std::string& dataset, std::uint64_t bytes) const;

  std::filesystem::path path_;
  std::int64_t file_ = -1;
  std::uint64_t file_bytes_ = 0;
};

}  // namespace mlcg::io
