#include "io/h5.hpp"

#include <hdf5.h>

#include <algorithm>
#include <cstring>
#include <stdexcept>
#include <type_traits>

namespace mlcg::io {
namespace fs = std::filesystem;

static_assert(std::is_same_v<hid_t, std::int64_t>, "h5.hpp stores hid_t as int64_t (HDF5 >= 1.10)");
static_assert(sizeof(Vec3) == 3 * sizeof(double), "Vec3 arrays are written as n x 3 doubles");

namespace {

constexpr size_t kCoreIncrement = 4u << 20;  // the in-memory file grows by 4 MiB

// Library-wide: silence HDF5's stderr dump; we turn failures into exceptions.
// Per thread in thread-safe builds, hence called from every constructor.
void silence_hdf5() { H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr); }

herr_t collect_error(unsigned n, const H5E_error2_t* e, void* data) {
  auto* s = static_cast<std::string*>(data);
  if (n < 3 && e->desc && *e->desc) {  // the outermost few messages are the useful ones
    if (!s->empty()) s->append("; ");
    s->append(e->desc);
  }
  return 0;
}

std::string h5_error_text() {
  std::string s;
  H5Ewalk2(H5E_DEFAULT, H5E_WALK_DOWNWARD, collect_error, &s);
  H5Eclear2(H5E_DEFAULT);
  return s.empty() ? "HDF5 error" : s;
}

// Owns one hid_t and closes it with the matching H5?close.
class Hid {
 public:
  Hid(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
  ~Hid() { if (id_ >= 0) close_(id_); }
  Hid(const Hid&) = delete;
  Hid& operator=(const Hid&) = delete;
  operator hid_t() const { return id_; }
  bool ok() const { return id_ >= 0; }

 private:
  hid_t id_;
  herr_t (*close_)(hid_t);
};

[[noreturn]] void fail(const std::string& msg) { throw std::runtime_error(msg + ": " + h5_error_text()); }

hid_t check(hid_t id, const std::string& msg) {
  if (id < 0) fail(msg);
  return id;
}

std::string norm(const std::string& p) {
  if (p.empty() || p == "/") return "/";
  return p.front() == '/' ? p : "/" + p;
}

template <class T> hid_t file_type();
template <> hid_t file_type<double>() { return H5T_IEEE_F64LE; }
template <> hid_t file_type<std::int64_t>() { return H5T_STD_I64LE; }
template <> hid_t file_type<std::int32_t>() { return H5T_STD_I32LE; }
template <> hid_t file_type<std::uint64_t>() { return H5T_STD_U64LE; }
template <> hid_t file_type<std::uint8_t>() { return H5T_STD_U8LE; }
template <class T> hid_t mem_type();
template <> hid_t mem_type<double>() { return H5T_NATIVE_DOUBLE; }
template <> hid_t mem_type<std::int64_t>() { return H5T_NATIVE_INT64; }
template <> hid_t mem_type<std::int32_t>() { return H5T_NATIVE_INT32; }
template <> hid_t mem_type<std::uint64_t>() { return H5T_NATIVE_UINT64; }
template <> hid_t mem_type<std::uint8_t>() { return H5T_NATIVE_UINT8; }

template <class T> const char* type_name();
template <> const char* type_name<double>() { return "float64"; }
template <> const char* type_name<std::int64_t>() { return "int64"; }
template <> const char* type_name<std::int32_t>() { return "int32"; }
template <> const char* type_name<std::uint64_t>() { return "uint64"; }
template <> const char* type_name<std::uint8_t>() { return "uint8"; }

std::string describe(hid_t type) {
  const H5T_class_t c = H5Tget_class(type);
  const size_t bits = H5Tget_size(type) * 8;
  switch (c) {
    case H5T_FLOAT: return "float" + std::to_string(bits);
    case H5T_INTEGER: return (H5Tget_sign(type) == H5T_SGN_NONE ? "uint" : "int") + std::to_string(bits);
    case H5T_STRING: return "string";
    default: return "HDF5 type class " + std::to_string(static_cast<int>(c));
  }
}

// Built with += : "'" + std::string&& trips a GCC 12 -Wrestrict false positive.
std::string quote_object(const fs::path& file, const std::string& obj) {
  std::string s = "'";
  s += file.string();
  s += "' object '";
  s += norm(obj);
  s += '\'';
  return s;
}

// File access: STRONG close degree (H5Fclose closes every object still open, so
// the file is complete on commit) and no flock: files are private while written
// and immutable once renamed, and flock fails on some cluster file systems.
hid_t make_fapl() {
  const hid_t fapl = check(H5Pcreate(H5P_FILE_ACCESS), "H5Pcreate");
  H5Pset_fclose_degree(fapl, H5F_CLOSE_STRONG);
#if H5_VERSION_GE(1, 10, 7)
  H5Pset_file_locking(fapl, false, true);
#endif
  return fapl;
}

}  // namespace

// ---------------------------------------------------------------- H5Writer

H5Writer::H5Writer(fs::path path) : tmp_(std::move(path)) {
  silence_hdf5();
  // The file is built in memory (the core driver, no backing store) and written by commit() with
  // plain POSIX calls: a full disk is then a clean exception naming the file, never HDF5 failing
  // to flush a half-written file (which left it open and crashed HDF5's teardown at exit).
  Hid fapl(make_fapl(), H5Pclose);
  if (H5Pset_fapl_core(fapl, kCoreIncrement, false) < 0) fail("H5Writer: cannot set the in-memory driver");
  file_ = H5Fcreate(tmp_.temp_path().c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, fapl);
  if (file_ < 0) fail("H5Writer: cannot create '" + tmp_.temp_path().string() + "'");
}

H5Writer::~H5Writer() {
  if (file_ >= 0) H5Fclose(file_);
  // tmp_'s destructor removes the temp file unless committed.
}

H5Writer::H5Writer(H5Writer&& o) noexcept
    : tmp_(std::move(o.tmp_)), file_(o.file_), compress_(o.compress_), level_(o.level_),
      committed_(o.committed_) {
  o.file_ = -1;
}

std::string H5Writer::where(const std::string& obj) const { return quote_object(tmp_.final_path(), obj); }

void H5Writer::require_open(const std::string& what) const {
  if (file_ < 0) throw std::runtime_error("H5Writer: " + what + " on closed file '" + path().string() + "'");
}

void H5Writer::set_compression(bool on, int level) {
  if (on && H5Zfilter_avail(H5Z_FILTER_DEFLATE) <= 0)
    throw std::runtime_error("H5Writer: gzip filter not available in this HDF5 build");
  compress_ = on;
  level_ = std::clamp(level, 1, 9);
}

void H5Writer::create_group(const std::string& path) {
  require_open("create_group");
  Hid lcpl(check(H5Pcreate(H5P_LINK_CREATE), "H5Pcreate"), H5Pclose);
  H5Pset_create_intermediate_group(lcpl, 1);
  Hid g(H5Gcreate2(file_, norm(path).c_str(), lcpl, H5P_DEFAULT, H5P_DEFAULT), H5Gclose);
  if (!g.ok()) fail("H5Writer: cannot create group " + where(path));
}

void H5Writer::write_raw(const std::string& path, std::int64_t ftype, std::int64_t mtype, const void* data,
                         const std::vector<std::uint64_t>& dims) {
  require_open("write");
  if (dims.empty()) throw std::runtime_error("H5Writer: dataset " + where(path) + " needs rank >= 1");
  std::vector<hsize_t> hd(dims.begin(), dims.end());
  hsize_t total = 1;
  for (hsize_t d : hd) total *= d;
  if (total > 0 && data == nullptr) throw std::runtime_error("H5Writer: null data for " + where(path));

  Hid space(check(H5Screate_simple(static_cast<int>(hd.size()), hd.data(), nullptr), "H5Screate_simple"),
            H5Sclose);
  Hid lcpl(check(H5Pcreate(H5P_LINK_CREATE), "H5Pcreate"), H5Pclose);
  H5Pset_create_intermediate_group(lcpl, 1);
  Hid dcpl(check(H5Pcreate(H5P_DATASET_CREATE), "H5Pcreate"), H5Pclose);
  if (compress_ && total >= 4096) {
    // ~1 MiB chunks along the first axis; the other axes stay whole.
    std::vector<hsize_t> chunk = hd;
    const hsize_t inner = std::max<hsize_t>(1, total / hd[0]);
    const hsize_t elems = (1u << 20) / H5Tget_size(ftype);
    chunk[0] = std::clamp<hsize_t>(elems / inner, 1, hd[0]);
    if (H5Pset_chunk(dcpl, static_cast<int>(chunk.size()), chunk.data()) < 0 || H5Pset_shuffle(dcpl) < 0 ||
        H5Pset_deflate(dcpl, static_cast<unsigned>(level_)) < 0)
      fail("H5Writer: cannot set compression for " + where(path));
  }
  Hid ds(H5Dcreate2(file_, norm(path).c_str(), ftype, space, lcpl, dcpl, H5P_DEFAULT), H5Dclose);
  if (!ds.ok()) fail("H5Writer: cannot create dataset " + where(path));
  // H5Dwrite rejects a null buffer even for zero elements; nothing to write then.
  if (total > 0 && H5Dwrite(ds, mtype, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0)
    fail("H5Writer: cannot write dataset " + where(path));
}

template <H5Element T>
void H5Writer::write(const std::string& path, const T* data, std::size_t n) {
  write_raw(path, file_type<T>(), mem_type<T>(), data, {n});
}

template <H5Element T>
void H5Writer::write_shaped(const std::string& path, const T* data, const std::vector<std::uint64_t>& dims) {
  write_raw(path, file_type<T>(), mem_type<T>(), data, dims);
}

void H5Writer::write_vec3(const std::string& path, const Vec3* data, std::size_t n) {
  write_raw(path, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, reinterpret_cast<const double*>(data), {n, 3});
}

void H5Writer::set_attr_raw(const std::string& obj, const std::string& name, std::int64_t ftype,
                            std::int64_t mtype, const void* v) {
  require_open("set_attr");
  Hid o(H5Oopen(file_, norm(obj).c_str(), H5P_DEFAULT), H5Oclose);
  if (!o.ok()) fail("H5Writer: no object " + where(obj) + " for attribute '" + name + "'");
  if (H5Aexists(o, name.c_str()) > 0 && H5Adelete(o, name.c_str()) < 0)
    fail("H5Writer: cannot replace attribute '" + name + "' on " + where(obj));
  Hid space(check(H5Screate(H5S_SCALAR), "H5Screate"), H5Sclose);
  Hid a(H5Acreate2(o, name.c_str(), ftype, space, H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  if (!a.ok() || H5Awrite(a, mtype, v) < 0) fail("H5Writer: cannot write attribute '" + name + "' on " + where(obj));
}

void H5Writer::set_attr(const std::string& obj, const std::string& name, double v) {
  set_attr_raw(obj, name, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, &v);
}
void H5Writer::set_attr_i64(const std::string& obj, const std::string& name, std::int64_t v) {
  set_attr_raw(obj, name, H5T_STD_I64LE, H5T_NATIVE_INT64, &v);
}
void H5Writer::set_attr_u64(const std::string& obj, const std::string& name, std::uint64_t v) {
  set_attr_raw(obj, name, H5T_STD_U64LE, H5T_NATIVE_UINT64, &v);
}

void H5Writer::set_attr(const std::string& obj, const std::string& name, std::string_view v) {
  // Fixed-length, null-padded; HDF5 forbids size 0, so "" is stored as one NUL.
  std::string buf(v);
  if (buf.empty()) buf.push_back('\0');
  Hid t(check(H5Tcopy(H5T_C_S1), "H5Tcopy"), H5Tclose);
  if (H5Tset_size(t, buf.size()) < 0 || H5Tset_strpad(t, H5T_STR_NULLPAD) < 0 || H5Tset_cset(t, H5T_CSET_UTF8) < 0)
    fail("H5Writer: cannot build string type for attribute '" + name + "'");
  set_attr_raw(obj, name, t, t, buf.data());
}

void H5Writer::commit() {
  require_open("commit");
  std::string image;
  const ssize_t n = H5Fflush(file_, H5F_SCOPE_GLOBAL) < 0 ? -1 : H5Fget_file_image(file_, nullptr, 0);
  if (n > 0) {
    image.resize(static_cast<size_t>(n));
    if (H5Fget_file_image(file_, image.data(), image.size()) != n) image.clear();
  }
  const herr_t rc = H5Fclose(file_);  // in memory: nothing is written here
  file_ = -1;
  if (image.empty() || rc < 0) fail("H5Writer: cannot complete '" + tmp_.final_path().string() + "' in memory");
  write_temp(tmp_, image);
  tmp_.commit();
  committed_ = true;
}

template void H5Writer::write<double>(const std::string&, const double*, std::size_t);
template void H5Writer::write<std::int64_t>(const std::string&, const std::int64_t*, std::size_t);
template void H5Writer::write<std::int32_t>(const std::string&, const std::int32_t*, std::size_t);
template void H5Writer::write<std::uint64_t>(const std::string&, const std::uint64_t*, std::size_t);
template void H5Writer::write<std::uint8_t>(const std::string&, const std::uint8_t*, std::size_t);
template void H5Writer::write_shaped<double>(const std::string&, const double*, const std::vector<std::uint64_t>&);
template void H5Writer::write_shaped<std::int64_t>(const std::string&, const std::int64_t*,
                                                   const std::vector<std::uint64_t>&);
template void H5Writer::write_shaped<std::int32_t>(const std::string&, const std::int32_t*,
                                                   const std::vector<std::uint64_t>&);
template void H5Writer::write_shaped<std::uint64_t>(const std::string&, const std::uint64_t*,
                                                    const std::vector<std::uint64_t>&);
template void H5Writer::write_shaped<std::uint8_t>(const std::string&, const std::uint8_t*,
                                                   const std::vector<std::uint64_t>&);

// ---------------------------------------------------------------- H5Reader

H5Reader::H5Reader(fs::path path) : path_(std::move(path)) {
  silence_hdf5();
  std::error_code ec;
  if (!fs::is_regular_file(path_, ec)) throw std::runtime_error("H5Reader: no such file '" + path_.string() + "'");
  file_bytes_ = fs::file_size(path_, ec);
  Hid fapl(make_fapl(), H5Pclose);
  file_ = H5Fopen(path_.c_str(), H5F_ACC_RDONLY, fapl);
  if (file_ < 0) fail("H5Reader: cannot open '" + path_.string() + "' as HDF5");
}

H5Reader::~H5Reader() {
  if (file_ >= 0) H5Fclose(file_);
}

H5Reader::H5Reader(H5Reader&& o) noexcept : path_(std::move(o.path_)), file_(o.file_), file_bytes_(o.file_bytes_) {
  o.file_ = -1;
}

std::string H5Reader::where(const std::string& obj) const { return quote_object(path_, obj); }

bool H5Reader::has(const std::string& path) const {
  // H5Lexists fails (rather than returning 0) if an intermediate link is
  // missing, so walk the components one by one.
  const std::string p = norm(path);
  if (p == "/") return true;
  size_t pos = 1;
  while (true) {
    const size_t slash = p.find('/', pos);
    const std::string prefix = p.substr(0, slash);
    if (H5Lexists(file_, prefix.c_str(), H5P_DEFAULT) <= 0) { H5Eclear2(H5E_DEFAULT); return false; }
    if (H5Oexists_by_name(file_, prefix.c_str(), H5P_DEFAULT) <= 0) { H5Eclear2(H5E_DEFAULT); return false; }
    if (slash == std::string::npos) return true;
    pos = slash + 1;
  }
}

bool H5Reader::has_attr(const std::string& obj, const std::string& name) const {
  if (!has(obj)) return false;
  const htri_t r = H5Aexists_by_name(file_, norm(obj).c_str(), name.c_str(), H5P_DEFAULT);
  H5Eclear2(H5E_DEFAULT);
  return r > 0;
}

std::int64_t H5Reader::open_dataset(const std::string& dataset) const {
  if (!has(dataset)) throw std::runtime_error("H5Reader: dataset not found: " + where(dataset));
  const hid_t ds = H5Dopen2(file_, norm(dataset).c_str(), H5P_DEFAULT);
  if (ds < 0) fail("H5Reader: " + where(dataset) + " is not a dataset");
  return ds;
}

void H5Reader::check_stored(std::int64_t ds, const std::string& dataset, std::uint64_t bytes) const {
  if (bytes == 0) return;
  // Its data must be in the file: all of it when stored plain, at least 1/1100 of it compressed (deflate
  // packs at most 1032:1), and never more than the file's size. A damaged size field may claim terabytes.
  const std::uint64_t stored = H5Dget_storage_size(ds);
  Hid dcpl(check(H5Dget_create_plist(ds), "H5Dget_create_plist"), H5Pclose);
  const double most = H5Pget_nfilters(dcpl) > 0 ? 1100.0 * static_cast<double>(stored) : static_cast<double>(stored);
  if (stored > file_bytes_ || static_cast<double>(bytes) > most)
    throw std::runtime_error("H5Reader: dataset " + where(dataset) + " claims " + std::to_string(bytes) +
                             " bytes of data, of which the file (" + std::to_string(file_bytes_) + " bytes) stores " +
                             std::to_string(stored) + "; the file is damaged or cut short");
}

std::vector<std::uint64_t> H5Reader::shape(const std::string& dataset) const {
  Hid ds(open_dataset(dataset), H5Dclose);
  Hid space(check(H5Dget_space(ds), "H5Dget_space"), H5Sclose);
  const int rank = H5Sget_simple_extent_ndims(space);
  if (rank < 0) fail("H5Reader: cannot get shape of " + where(dataset));
  std::vector<hsize_t> d(static_cast<size_t>(rank));
  H5Sget_simple_extent_dims(space, d.data(), nullptr);
  return {d.begin(), d.end()};
}

template <H5Element T>
std::vector<T> H5Reader::read(const std::string& dataset) const {
  Hid ds(open_dataset(dataset), H5Dclose);
  Hid type(check(H5Dget_type(ds), "H5Dget_type"), H5Tclose);
  const bool want_float = std::is_floating_point_v<T>;
  const H5T_class_t cls = H5Tget_class(type);
  const bool match = (want_float ? cls == H5T_FLOAT : cls == H5T_INTEGER) && H5Tget_size(type) == sizeof(T) &&
                     (want_float || (H5Tget_sign(type) == H5T_SGN_NONE) == std::is_unsigned_v<T>);
  if (!match)
    throw std::runtime_error("H5Reader: dataset " + where(dataset) + " has type " + describe(type) +
                             ", expected " + type_name<T>());
  Hid space(check(H5Dget_space(ds), "H5Dget_space"), H5Sclose);
  const hssize_t n = H5Sget_simple_extent_npoints(space);
  if (n < 0) fail("H5Reader: cannot size " + where(dataset));
  check_stored(ds, dataset, static_cast<std::uint64_t>(n) * sizeof(T));
  std::vector<T> out(static_cast<size_t>(n));
  if (n > 0 && H5Dread(ds, mem_type<T>(), H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data()) < 0)
    fail("H5Reader: cannot read " + where(dataset));
  return out;
}

std::vector<Vec3> H5Reader::read_vec3(const std::string& dataset) const {
  const auto s = shape(dataset);
  if (s.size() != 2 || s[1] != 3)
    throw std::runtime_error("H5Reader: dataset " + where(dataset) + " is not of shape (n, 3)");
  const std::vector<double> flat = read<double>(dataset);
  std::vector<Vec3> out(flat.size() / 3);
  if (!flat.empty()) std::memcpy(static_cast<void*>(out.data()), flat.data(), flat.size() * sizeof(double));
  return out;
}

std::int64_t H5Reader::open_attr(const std::string& obj, const std::string& name) const {
  if (!has_attr(obj, name))
    throw std::runtime_error("H5Reader: attribute '" + name + "' not found on " + where(obj));
  const hid_t a = H5Aopen_by_name(file_, norm(obj).c_str(), name.c_str(), H5P_DEFAULT, H5P_DEFAULT);
  if (a < 0) fail("H5Reader: cannot open attribute '" + name + "' on " + where(obj));
  return a;
}

void H5Reader::read_attr_number(const std::string& obj, const std::string& name, bool want_float, int want_sign,
                                std::int64_t mtype, void* out) const {
  Hid a(open_attr(obj, name), H5Aclose);
  Hid type(check(H5Aget_type(a), "H5Aget_type"), H5Tclose);
  Hid space(check(H5Aget_space(a), "H5Aget_space"), H5Sclose);
  const H5T_class_t cls = H5Tget_class(type);
  // Integers may widen (int32 -> int64) but signedness must match: HDF5 would
  // otherwise clamp silently.
  const bool ok = want_float ? cls == H5T_FLOAT
                             : cls == H5T_INTEGER && (H5Tget_sign(type) == H5T_SGN_NONE) == (want_sign == 0);
  if (!ok || H5Sget_simple_extent_npoints(space) != 1)
    throw std::runtime_error("H5Reader: attribute '" + name + "' on " + where(obj) + " is " + describe(type) +
                             ", not a scalar " + (want_float ? "float" : want_sign ? "signed integer" : "unsigned integer"));
  if (H5Aread(a, mtype, out) < 0) fail("H5Reader: cannot read attribute '" + name + "' on " + where(obj));
}

double H5Reader::attr_double(const std::string& obj, const std::string& name) const {
  double v = 0;
  read_attr_number(obj, name, true, 1, H5T_NATIVE_DOUBLE, &v);
  return v;
}
std::int64_t H5Reader::attr_int64(const std::string& obj, const std::string& name) const {
  std::int64_t v = 0;
  read_attr_number(obj, name, false, 1, H5T_NATIVE_INT64, &v);
  return v;
}
std::uint64_t H5Reader::attr_uint64(const std::string& obj, const std::string& name) const {
  std::uint64_t v = 0;
  read_attr_number(obj, name, false, 0, H5T_NATIVE_UINT64, &v);
  return v;
}

std::string H5Reader::attr_string(const std::string& obj, const std::string& name) const {
  Hid a(open_attr(obj, name), H5Aclose);
  Hid type(check(H5Aget_type(a), "H5Aget_type"), H5Tclose);
  if (H5Tget_class(type) != H5T_STRING)
    throw std::runtime_error("H5Reader: attribute '" + name + "' on " + where(obj) + " is " + describe(type) +
                             ", not a string");
  if (H5Tis_variable_str(type) > 0) {  // e.g. written by h5py
    Hid mt(check(H5Tcopy(H5T_C_S1), "H5Tcopy"), H5Tclose);
    H5Tset_size(mt, H5T_VARIABLE);
    H5Tset_cset(mt, H5Tget_cset(type));
    char* s = nullptr;
    if (H5Aread(a, mt, &s) < 0) fail("H5Reader: cannot read attribute '" + name + "' on " + where(obj));
    std::string out = s ? s : "";
    H5free_memory(s);
    return out;
  }
  if (H5Tget_size(type) > file_bytes_)  // a damaged size field
    throw std::runtime_error("H5Reader: attribute '" + name + "' on " + where(obj) + " claims a string of " +
                             std::to_string(H5Tget_size(type)) + " bytes, more than the file holds");
  std::string buf(H5Tget_size(type), '\0');
  if (H5Aread(a, type, buf.data()) < 0) fail("H5Reader: cannot read attribute '" + name + "' on " + where(obj));
  buf.resize(std::strlen(buf.c_str()));  // drop null padding / terminator
  return buf;
}

template std::vector<double> H5Reader::read<double>(const std::string&) const;
template std::vector<std::int64_t> H5Reader::read<std::int64_t>(const std::string&) const;
template std::vector<std::int32_t> H5Reader::read<std::int32_t>(const std::string&) const;
template std::vector<std::uint64_t> H5Reader::read<std::uint64_t>(const std::string&) const;
template std::vector<std::uint8_t> H5Reader::read<std::uint8_t>(const std::string&) const;

}  // namespace mlcg::io
