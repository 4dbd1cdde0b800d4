#include "snapshot.hpp"

#include <hdf5.h>

#include <stdexcept>
#include <string>

namespace mlcg::bench {

namespace {

[[noreturn]] void fail(const std::filesystem::path& f, const std::string& what) {
  throw std::runtime_error(f.string() + ": " + what);
}

template <class T>
hid_t native();
template <>
hid_t native<double>() { return H5T_NATIVE_DOUBLE; }
template <>
hid_t native<std::int64_t>() { return H5T_NATIVE_INT64; }

template <class T>
std::vector<T> read_dataset(hid_t file, const std::filesystem::path& path, const char* name, int cols) {
  const hid_t d = H5Dopen2(file, name, H5P_DEFAULT);
  if (d < 0) fail(path, std::string("no dataset '") + name + "'");
  const hid_t sp = H5Dget_space(d);
  hsize_t dims[2] = {0, 0};
  const int rank = H5Sget_simple_extent_ndims(sp);
  H5Sget_simple_extent_dims(sp, dims, nullptr);
  H5Sclose(sp);
  const bool ok = cols == 1 ? rank == 1 : (rank == 2 && dims[1] == static_cast<hsize_t>(cols));
  if (!ok) {
    H5Dclose(d);
    fail(path, std::string("dataset '") + name + "' has an unexpected shape");
  }
  std::vector<T> out(static_cast<size_t>(dims[0]) * static_cast<size_t>(cols));
  if (!out.empty() && H5Dread(d, native<T>(), H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data()) < 0) {
    H5Dclose(d);
    fail(path, std::string("cannot read '") + name + "'");
  }
  H5Dclose(d);
  return out;
}

template <class T>
void write_dataset(hid_t file, const std::filesystem::path& path, const char* name, const std::vector<T>& data,
                   size_t n, int cols) {
  hsize_t dims[2] = {static_cast<hsize_t>(n), static_cast<hsize_t>(cols)};
  const hid_t sp = H5Screate_simple(cols == 1 ? 1 : 2, dims, nullptr);
  const hid_t d = H5Dcreate2(file, name, native<T>(), sp, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  H5Sclose(sp);
  if (d < 0) fail(path, std::string("cannot create '") + name + "'");
  const herr_t e = n > 0 ? H5Dwrite(d, native<T>(), H5S_ALL, H5S_ALL, H5P_DEFAULT, data.data()) : 0;
  H5Dclose(d);
  if (e < 0) fail(path, std::string("cannot write '") + name + "'");
}

}  // namespace

Snapshot read_snapshot(const std::filesystem::path& file) {
  const hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (f < 0) fail(file, "cannot open as HDF5");
  Snapshot s;
  try {
    s.x = read_dataset<double>(f, file, "position", 3);
    s.v = read_dataset<double>(f, file, "velocity", 3);
    s.w = read_dataset<double>(f, file, "omega", 3);
    s.radius = read_dataset<double>(f, file, "radius", 1);
    s.id = read_dataset<std::int64_t>(f, file, "id", 1);
  } catch (...) {
    H5Fclose(f);
    throw;
  }
  H5Fclose(f);
  const size_t n = s.radius.size();
  if (s.x.size() != 3 * n || s.v.size() != 3 * n || s.w.size() != 3 * n || s.id.size() != n)
    fail(file, "datasets differ in length");
  return s;
}

void write_snapshot(const std::filesystem::path& file, const Snapshot& s) {
  const auto tmp = std::filesystem::path(file.string() + ".tmp");
  const hid_t f = H5Fcreate(tmp.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  if (f < 0) fail(tmp, "cannot create");
  const size_t n = s.size();
  try {
    write_dataset(f, tmp, "position", s.x, n, 3);
    write_dataset(f, tmp, "velocity", s.v, n, 3);
    write_dataset(f, tmp, "omega", s.w, n, 3);
    write_dataset(f, tmp, "radius", s.radius, n, 1);
    write_dataset(f, tmp, "id", s.id, n, 1);
  } catch (...) {
    H5Fclose(f);
    throw;
  }
  if (H5Fclose(f) < 0) fail(tmp, "cannot close");
  std::filesystem::rename(tmp, file);
}

}  // namespace mlcg::bench
