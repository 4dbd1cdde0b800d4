// File-output layer: atomic replacement, HDF5 round trips, XDMF series.
#include <gtest/gtest.h>
#include <hdf5.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <regex>

#include "files.hpp"
#include "io/atomic_file.hpp"
#include "io/grid_series.hpp"
#include "io/h5.hpp"
#include "io/snapshot_series.hpp"

namespace fs = std::filesystem;
using namespace mlcg;
using namespace mlcg::io;

namespace {

using mlcg::test::slurp;

// A folder of its own for each test case.
class IoTest : public ::testing::Test {
 protected:
  const mlcg::test::TempDir tmp{std::string("test_io_") +
                                ::testing::UnitTest::GetInstance()->current_test_info()->name()};
  const fs::path dir = tmp.path();
};

int count_temps(const fs::path& d) {
  int n = 0;
  for (const auto& e : fs::recursive_directory_iterator(d))
    if (e.path().filename().string().find(".tmp.") != std::string::npos) ++n;
  return n;
}

int count_of(const std::string& s, const std::string& what) {
  int n = 0;
  for (size_t p = s.find(what); p != std::string::npos; p = s.find(what, p + 1)) ++n;
  return n;
}

template <class T>
bool bitwise_equal(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0);
}

// Minimal XML well-formedness check: every '<' opens a valid tag (quoted
// attributes), tags nest properly, one root; <?...?> and <!DOCTYPE ...> skipped.
// Returns "" when fine, else what is wrong.
std::string xml_error(const std::string& s) {
  static const std::regex tag(R"(<(/?)([A-Za-z_][\w:.-]*)((?:\s+[\w:.-]+\s*=\s*(?:"[^"<]*"|'[^'<]*'))*)\s*(/?)>)");
  std::vector<std::string> stack;
  int roots = 0;
  for (size_t i = s.find('<'); i != std::string::npos; i = s.find('<', i + 1)) {
    if (s.compare(i, 2, "<?") == 0 || s.compare(i, 9, "<!DOCTYPE") == 0) {
      const size_t j = s.find(s[i + 1] == '?' ? "?>" : ">", i);
      if (j == std::string::npos) return "unterminated prolog";
      i = j;
      continue;
    }
    std::smatch m;
    if (!std::regex_search(s.begin() + i, s.end(), m, tag, std::regex_constants::match_continuous))
      return "bad tag at offset " + std::to_string(i);
    const bool closing = m[1].length() > 0, self_close = m[4].length() > 0;
    if (closing && (self_close || m[3].length() > 0)) return "bad closing tag " + m[2].str();
    if (closing) {
      if (stack.empty() || stack.back() != m[2].str()) return "mismatched </" + m[2].str() + ">";
      stack.pop_back();
    } else {
      if (stack.empty()) ++roots;
      if (!self_close) stack.push_back(m[2].str());
    }
    i += static_cast<size_t>(m.length()) - 1;
  }
  if (!stack.empty()) return "unclosed <" + stack.back() + ">";
  return roots == 1 ? "" : std::to_string(roots) + " root elements";
}

// scripts/setup.sh installs python3-h5py: a test that needs it fails without it (issue 34, item 10), never skips.
bool have_h5py() {
  static const bool ok = fs::exists("/usr/bin/python3") &&
                         std::system("/usr/bin/python3 -c 'import h5py' >/dev/null 2>&1") == 0;
  return ok;
}

// Runs python code (argv[1] = arg) and returns its stdout, trimmed.
std::string run_python(const fs::path& work, const std::string& code, const std::string& arg) {
  const fs::path script = work / "check.py", out = work / "check.out";
  std::ofstream(script) << code;
  const std::string cmd =
      "/usr/bin/python3 '" + script.string() + "' '" + arg + "' > '" + out.string() + "' 2>&1";
  const int rc = std::system(cmd.c_str());
  std::string r = slurp(out);
  while (!r.empty() && std::isspace(static_cast<unsigned char>(r.back()))) r.pop_back();
  fs::remove(script);
  fs::remove(out);
  return rc == 0 ? r : "python failed: " + r;
}

// Parses an xmf like ParaView would need: every HDF DataItem must name an
// existing dataset whose shape, width and kind match the XML. Prints "OK <grids>".
const char* kXdmfCheck = R"PY(
import os, sys, h5py, xml.etree.ElementTree as ET
xmf = sys.argv[1]
coll = ET.parse(xmf).getroot().find('Domain/Grid')
assert coll.get('CollectionType') == 'Temporal'
grids = coll.findall('Grid')
for g in grids:
    float(g.find('Time').get('Value'))
    for di in g.iter('DataItem'):
        if di.get('Format') != 'HDF':
            continue
        f, d = di.text.strip().split(':')
        dims = tuple(int(x) for x in di.get('Dimensions').split())
        with h5py.File(os.path.join(os.path.dirname(xmf), f), 'r') as h:
            ds = h[d]
            assert ds.shape == dims, (f, d, ds.shape, dims)
            assert ds.dtype.itemsize == int(di.get('Precision')), (f, d)
            assert ds.dtype.kind == ('f' if di.get('NumberType') == 'Float' else 'i'), (f, d)
print('OK', len(grids))
)PY";

void write_particles(SnapshotSeries& s, double t, uint64_t step, size_t n, double seed) {
  std::vector<Vec3> x(n), v(n), w(n);
  std::vector<double> r(n);
  std::vector<int64_t> id(n);
  for (size_t i = 0; i < n; ++i) {
    x[i] = {seed + i, 2.0 * i, -1.0 * i};
    v[i] = {0.5 * i, seed, 0.0};
    w[i] = {0.0, 0.0, seed * i};
    r[i] = 0.001 * (i + 1);
    id[i] = static_cast<int64_t>(1000 + i);
  }
  s.write(t, step, n, x.data(), v.data(), w.data(), r.data(), id.data());
}

}  // namespace

// ------------------------------------------------------------------ atomic files

TEST_F(IoTest, AtomicWriteReplacesContentAndLeavesNoTemp) {
  const fs::path p = dir / "sub" / "a.txt";
  write_file_atomic(p, "first");
  EXPECT_EQ(slurp(p), "first");
  write_file_atomic(p, std::string("second\0x", 8));
  EXPECT_EQ(slurp(p), std::string("second\0x", 8));
  EXPECT_EQ(count_temps(dir), 0);
}

TEST_F(IoTest, AtomicPathWithoutCommitKeepsOldFileAndRemovesTemp) {
  const fs::path p = dir / "b.txt";
  write_file_atomic(p, "old");
  {
    AtomicPath ap(p);
    std::ofstream(ap.temp_path()) << "new, half written";
    EXPECT_TRUE(fs::exists(ap.temp_path()));
    EXPECT_EQ(ap.temp_path().parent_path(), p.parent_path());
  }
  EXPECT_EQ(slurp(p), "old");
  EXPECT_EQ(count_temps(dir), 0);
}

TEST_F(IoTest, AtomicWriteErrorNamesPath) {
  write_file_atomic(dir / "plain", "x");
  try {
    write_file_atomic(dir / "plain" / "child.txt", "y");  // parent is a file
    FAIL() << "expected an exception";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("plain"), std::string::npos) << e.what();
  }
}

TEST_F(IoTest, StaleTempsOfDeadProcessesAreRemoved) {
  const pid_t child = ::fork();
  if (child == 0) ::_exit(0);
  ::waitpid(child, nullptr, 0);
  const fs::path dead = dir / ("p_000001.h5.tmp." + std::to_string(child) + ".0");
  const fs::path mine = dir / ("p_000002.h5.tmp." + std::to_string(::getpid()) + ".0");
  const fs::path other = dir / ("q_000001.h5.tmp." + std::to_string(child) + ".0");
  for (const auto& p : {dead, mine, other}) std::ofstream(p) << "x";
  remove_stale_temps(dir, "p_");
  EXPECT_FALSE(fs::exists(dead));
  EXPECT_TRUE(fs::exists(mine));   // live writer
  EXPECT_TRUE(fs::exists(other));  // other prefix
}

// ------------------------------------------------------------------ HDF5

TEST_F(IoTest, H5RoundTripEveryTypeBitwise) {
  const std::vector<double> d = {0.0, -0.0, std::numeric_limits<double>::denorm_min(), -1e-310,
                                 std::numeric_limits<double>::max(), std::numeric_limits<double>::lowest(),
                                 std::numeric_limits<double>::infinity(), 0.1, -1.0 / 3.0};
  const std::vector<int64_t> i64 = {std::numeric_limits<int64_t>::min(), -1, 0, std::numeric_limits<int64_t>::max()};
  const std::vector<int32_t> i32 = {std::numeric_limits<int32_t>::min(), -7, 0, std::numeric_limits<int32_t>::max()};
  const std::vector<uint64_t> u64 = {0, 1, std::numeric_limits<uint64_t>::max()};
  std::vector<uint8_t> u8(256);
  for (int k = 0; k < 256; ++k) u8[k] = static_cast<uint8_t>(k);
  const std::vector<Vec3> v3 = {{1, -0.0, 3}, {4e-320, 5, -6}};
  const fs::path p = dir / "rt.h5";
  {
    H5Writer w(p);
    w.write("a/b/d", d);
    w.write("i64", i64);
    w.write("g/i32", i32.data(), i32.size());
    w.write("u64", u64);
    w.write("u8", u8);
    w.write_vec3("v3", v3);
    w.write("empty", std::vector<double>{});
    w.write_shaped("m", d.data(), {3, 3});
    w.create_group("x/y");
    w.commit();
  }
  H5Reader r(p);
  EXPECT_TRUE(bitwise_equal(r.read<double>("a/b/d"), d));
  EXPECT_TRUE(bitwise_equal(r.read<int64_t>("/i64"), i64));
  EXPECT_TRUE(bitwise_equal(r.read<int32_t>("g/i32"), i32));
  EXPECT_TRUE(bitwise_equal(r.read<uint64_t>("u64"), u64));
  EXPECT_TRUE(bitwise_equal(r.read<uint8_t>("u8"), u8));
  const auto back = r.read_vec3("v3");
  ASSERT_EQ(back.size(), 2u);
  EXPECT_EQ(std::memcmp(back.data(), v3.data(), sizeof(Vec3) * 2), 0);
  EXPECT_EQ(r.shape("v3"), (std::vector<uint64_t>{2, 3}));
  EXPECT_EQ(r.shape("m"), (std::vector<uint64_t>{3, 3}));
  EXPECT_TRUE(r.read<double>("empty").empty());
  EXPECT_TRUE(r.has("x/y"));
  EXPECT_TRUE(r.has("a/b"));
  EXPECT_FALSE(r.has("a/c/d"));
  EXPECT_FALSE(r.has("nothing/at/all"));
}

TEST_F(IoTest, H5AttributesRoundTrip) {
  const fs::path p = dir / "attr.h5";
  {
    H5Writer w(p);
    w.write("g/x", std::vector<int32_t>{1});
    w.set_attr("", "neg0", -0.0);
    w.set_attr("/", "denorm", 5e-324);
    w.set_attr("g", "i64", std::numeric_limits<int64_t>::min());
    w.set_attr("g", "u64", std::numeric_limits<uint64_t>::max());
    w.set_attr("g/x", "s", std::string("héllo wörld"));
    w.set_attr("g/x", "empty", "");
    w.set_attr("/", "replaced", 1.0);
    w.set_attr("/", "replaced", 2.0);
    w.commit();
  }
  H5Reader r(p);
  EXPECT_TRUE(std::signbit(r.attr_double("/", "neg0")));
  EXPECT_EQ(r.attr_double("", "denorm"), 5e-324);
  EXPECT_EQ(r.attr_int64("g", "i64"), std::numeric_limits<int64_t>::min());
  EXPECT_EQ(r.attr_uint64("g", "u64"), std::numeric_limits<uint64_t>::max());
  EXPECT_EQ(r.attr_string("g/x", "s"), "héllo wörld");
  EXPECT_EQ(r.attr_string("g/x", "empty"), "");
  EXPECT_EQ(r.attr_double("/", "replaced"), 2.0);
  EXPECT_TRUE(r.has_attr("g", "u64"));
  EXPECT_FALSE(r.has_attr("g", "nope"));
  EXPECT_THROW(r.attr_int64("g", "u64"), std::runtime_error);  // signedness mismatch
  EXPECT_THROW(r.attr_string("/", "neg0"), std::runtime_error);
}

TEST_F(IoTest, H5ErrorsNameFileAndObject) {
  const fs::path p = dir / "err.h5";
  {
    H5Writer w(p);
    w.write("grp/ints", std::vector<int32_t>{1, 2});
    w.commit();
  }
  H5Reader r(p);
  const auto message = [](auto&& f) {
    try {
      f();
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string("no exception");
  };
  const std::string missing = message([&] { r.read<double>("grp/missing_thing"); });
  EXPECT_NE(missing.find("grp/missing_thing"), std::string::npos) << missing;
  EXPECT_NE(missing.find("err.h5"), std::string::npos) << missing;
  const std::string wrong = message([&] { r.read<double>("grp/ints"); });
  EXPECT_NE(wrong.find("grp/ints"), std::string::npos) << wrong;
  EXPECT_NE(wrong.find("int32"), std::string::npos) << wrong;
  EXPECT_THROW(r.read<int64_t>("grp/ints"), std::runtime_error);
  EXPECT_THROW(r.read<uint8_t>("grp/ints"), std::runtime_error);
  EXPECT_THROW(r.read_vec3("grp/ints"), std::runtime_error);
  const std::string attr = message([&] { r.attr_double("grp", "absent_attr"); });
  EXPECT_NE(attr.find("absent_attr"), std::string::npos) << attr;
  const std::string nofile = message([&] { H5Reader bad(dir / "does_not_exist.h5"); });
  EXPECT_NE(nofile.find("does_not_exist.h5"), std::string::npos) << nofile;
  write_file_atomic(dir / "garbage.h5", "this is not hdf5");
  const std::string garbage = message([&] { H5Reader bad(dir / "garbage.h5"); });
  EXPECT_NE(garbage.find("garbage.h5"), std::string::npos) << garbage;
}

TEST_F(IoTest, H5WriterIsAtomic) {
  const fs::path p = dir / "atomic.h5";
  {
    H5Writer w(p);
    w.write("x", std::vector<double>{1, 2, 3});
    EXPECT_FALSE(fs::exists(p));
    EXPECT_EQ(count_temps(dir), 0);  // built in memory: nothing is on disk before commit()
    w.commit();
    EXPECT_TRUE(w.committed());
    EXPECT_THROW(w.write("y", std::vector<double>{1}), std::runtime_error);
  }
  EXPECT_TRUE(fs::exists(p));
  EXPECT_EQ(count_temps(dir), 0);
  {
    H5Writer w(p);  // abandoned rewrite: the committed file must survive
    w.write("x", std::vector<double>{9});
    EXPECT_THROW(w.write("x", std::vector<double>{9}), std::runtime_error);  // duplicate
  }
  EXPECT_EQ(count_temps(dir), 0);
  EXPECT_EQ(H5Reader(p).read<double>("x"), (std::vector<double>{1, 2, 3}));
  { H5Writer w(dir / "never.h5"); }
  EXPECT_FALSE(fs::exists(dir / "never.h5"));
  EXPECT_EQ(count_temps(dir), 0);
}

// A write that fails on the disk (here a file-size limit, EFBIG, as ENOSPC would on a full disk) is an
// exception naming the file; the file committed before stays, no temporary is left, HDF5 goes on working.
TEST_F(IoTest, H5WriterFailingOnDiskNamesTheFileAndKeepsTheOldOne) {
  const fs::path p = dir / "kept.h5";
  {
    H5Writer w(p);
    w.write("x", std::vector<double>{1, 2, 3});
    w.commit();
  }
  std::string msg;
  {
    const auto old_handler = std::signal(SIGXFSZ, SIG_IGN);
    rlimit old{};
    getrlimit(RLIMIT_FSIZE, &old);
    rlimit small = old;
    small.rlim_cur = 64 * 1024;
    ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &small), 0);
    try {
      H5Writer w(p);
      w.write("x", std::vector<double>(1 << 20, 7.0));  // 8 MiB
      w.commit();
    } catch (const std::runtime_error& e) {
      msg = e.what();
    }
    setrlimit(RLIMIT_FSIZE, &old);
    std::signal(SIGXFSZ, old_handler);
  }
  EXPECT_NE(msg.find("'" + p.string() + "'"), std::string::npos) << msg;
  EXPECT_NE(msg.find(std::strerror(EFBIG)), std::string::npos) << msg;
  EXPECT_EQ(count_temps(dir), 0);
  EXPECT_EQ(H5Reader(p).read<double>("x"), (std::vector<double>{1, 2, 3}));
  H5Writer again(dir / "after.h5");
  again.write("y", std::vector<double>{4});
  again.commit();
  EXPECT_EQ(H5Reader(dir / "after.h5").read<double>("y"), (std::vector<double>{4}));
}

TEST_F(IoTest, H5CompressionRoundTripAndShrinks) {
  std::vector<double> big(200000);
  for (size_t i = 0; i < big.size(); ++i) big[i] = static_cast<double>(i % 97);
  std::vector<Vec3> v(50000, Vec3{1, 2, 3});
  for (bool on : {false, true}) {
    const fs::path p = dir / (on ? "z.h5" : "raw.h5");
    H5Writer w(p);
    w.set_compression(on);
    w.write("big", big);
    w.write_vec3("v", v);
    w.write("small", std::vector<int64_t>{1, 2});
    w.commit();
    H5Reader r(p);
    EXPECT_TRUE(bitwise_equal(r.read<double>("big"), big));
    EXPECT_EQ(r.read_vec3("v").size(), v.size());
    EXPECT_EQ(r.read_vec3("v")[49999], (Vec3{1, 2, 3}));
  }
  EXPECT_LT(fs::file_size(dir / "z.h5") * 4, fs::file_size(dir / "raw.h5"));
}

// What the fuzzer found (tests/fuzz/fuzz_level_checkpoint): a damaged dataset size made the reader
// allocate 26 GB. A dataset whose data the file cannot hold is refused, naming it; data compressed as far
// as deflate goes (all zeros) still reads.
TEST_F(IoTest, H5DatasetClaimingMoreDataThanTheFileHoldsIsRefused) {
  const fs::path p = dir / "claims.h5";
  const hid_t f = H5Fcreate(p.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  const hsize_t dims[1] = {hsize_t{1} << 40}, chunk[1] = {1024};
  const hid_t space = H5Screate_simple(1, dims, nullptr), dcpl = H5Pcreate(H5P_DATASET_CREATE);
  H5Pset_chunk(dcpl, 1, chunk);
  const hid_t ds = H5Dcreate2(f, "x", H5T_NATIVE_DOUBLE, space, H5P_DEFAULT, dcpl, H5P_DEFAULT);
  ASSERT_GE(ds, 0);
  H5Dclose(ds);
  H5Pclose(dcpl);
  H5Sclose(space);
  H5Fclose(f);
  const H5Reader r(p);
  try {
    r.read<double>("x");
    FAIL() << "expected a refusal";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("x' claims 8796093022208 bytes of data, of which the file ("),
              std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(p.string()), std::string::npos) << e.what();
  }
  const std::vector<double> zeros(1 << 21, 0.0);
  H5Writer w(dir / "zeros.h5");
  w.set_compression(true, 9);
  w.write("z", zeros);
  w.commit();
  EXPECT_EQ(H5Reader(dir / "zeros.h5").read<double>("z").size(), zeros.size());
}

// ------------------------------------------------------------------ snapshot series

TEST_F(IoTest, SnapshotSeriesWritesFilesAndXmf) {
  SnapshotSeries s(dir, "particles");
  const double times[] = {0.0, 0.25, 0.501};
  for (int k = 0; k < 3; ++k) write_particles(s, times[k], 100 * k, 5, k);
  ASSERT_EQ(s.size(), 3u);
  EXPECT_TRUE(fs::exists(dir / "particles" / "particles_000002.h5"));
  EXPECT_TRUE(fs::exists(dir / "particles" / "index.json"));
  const std::string xmf = slurp(dir / "particles.xmf");
  EXPECT_EQ(xml_error(xmf), "");
  EXPECT_EQ(count_of(xmf, "<Time Value="), 3);
  EXPECT_NE(xmf.find("<Time Value=\"0.501\"/>"), std::string::npos);
  EXPECT_NE(xmf.find("CollectionType=\"Temporal\""), std::string::npos);
  EXPECT_NE(xmf.find("particles/particles_000001.h5:/position"), std::string::npos);
  EXPECT_NE(xmf.find("particles/particles_000002.h5:/id"), std::string::npos);
  EXPECT_NE(xmf.find("NumberOfElements=\"5\""), std::string::npos);
  EXPECT_EQ(count_temps(dir), 0);

  H5Reader r(dir / "particles" / "particles_000001.h5");
  EXPECT_EQ(r.attr_double("/", "time"), 0.25);
  EXPECT_EQ(r.attr_uint64("/", "step"), 100u);
  EXPECT_EQ(r.read_vec3("position")[3], (Vec3{4, 6, -3}));
  EXPECT_EQ(r.read<int64_t>("id")[4], 1004);
  EXPECT_EQ(r.read<double>("radius")[0], 0.001);
  EXPECT_EQ(r.shape("omega"), (std::vector<uint64_t>{5, 3}));
}

TEST_F(IoTest, SnapshotSeriesResumeAppendsAndFreshRunRefusesExisting) {
  {
    SnapshotSeries s(dir, "particles");
    for (int k = 0; k < 3; ++k) write_particles(s, k, k, 4, k);
  }
  EXPECT_THROW(SnapshotSeries(dir, "particles", false), std::runtime_error);
  SnapshotSeries s(dir, "particles", true);
  ASSERT_EQ(s.size(), 3u);
  EXPECT_EQ(s.entries()[2].time, 2.0);
  for (int k = 3; k < 5; ++k) write_particles(s, k, k, 4, k);
  EXPECT_EQ(s.entries().back().index, 4u);
  const std::string xmf = slurp(s.xmf_path());
  EXPECT_EQ(count_of(xmf, "<Time Value="), 5);
  EXPECT_NE(xmf.find("particles/particles_000004.h5:/velocity"), std::string::npos);
  EXPECT_EQ(xml_error(xmf), "");
  SnapshotSeries again(dir, "particles", true);
  EXPECT_EQ(again.size(), 5u);
}

TEST_F(IoTest, SnapshotSeriesRestartReplacesLaterEntries) {
  SnapshotSeries s(dir, "p");
  for (int k = 0; k < 4; ++k) write_particles(s, k, k, 2, k);
  SnapshotSeries r(dir, "p", true);
  r.truncate_after(2.0);  // checkpoint at t = 2
  EXPECT_EQ(r.size(), 3u);
  EXPECT_FALSE(fs::exists(dir / "p" / "p_000003.h5"));
  write_particles(r, 1.5, 15, 2, 9);  // re-run writes at an earlier time: replaces t = 2
  ASSERT_EQ(r.size(), 3u);
  EXPECT_EQ(r.entries()[2].time, 1.5);
  EXPECT_EQ(r.entries()[2].index, 2u);
  EXPECT_EQ(H5Reader(dir / "p" / "p_000002.h5").attr_double("/", "time"), 1.5);
  write_particles(r, 0.5, 5, 2, 9);  // drops t = 1 and 1.5, deletes their files
  ASSERT_EQ(r.size(), 2u);
  EXPECT_EQ(r.entries()[1].index, 1u);
  EXPECT_EQ(H5Reader(dir / "p" / "p_000001.h5").attr_double("/", "time"), 0.5);
  EXPECT_FALSE(fs::exists(dir / "p" / "p_000002.h5"));
  EXPECT_EQ(count_of(slurp(r.xmf_path()), "<Time Value="), 2);
  EXPECT_EQ(SnapshotSeries(dir, "p", true).size(), 2u);
}

TEST_F(IoTest, SnapshotSeriesEmptySnapshotIsValid) {
  SnapshotSeries s(dir, "particles");
  s.write(0.0, 0, 0, nullptr, nullptr, nullptr, nullptr, nullptr);
  H5Reader r(dir / "particles" / "particles_000000.h5");
  EXPECT_EQ(r.shape("position"), (std::vector<uint64_t>{0, 3}));
  EXPECT_EQ(r.attr_uint64("/", "count"), 0u);
  EXPECT_TRUE(r.read<int64_t>("id").empty());
  const std::string xmf = slurp(s.xmf_path());
  EXPECT_EQ(xml_error(xmf), "");
  EXPECT_NE(xmf.find("Dimensions=\"0 3\""), std::string::npos);
  EXPECT_THROW(s.write(1.0, 1, 3, nullptr, nullptr, nullptr, nullptr, nullptr), std::invalid_argument);
  EXPECT_THROW(SnapshotSeries(dir, "bad/name"), std::invalid_argument);
}

TEST_F(IoTest, XmlCheckerRejectsBrokenDocuments) {
  EXPECT_EQ(xml_error("<?xml version=\"1.0\"?><a><b x=\"1\"/></a>"), "");
  EXPECT_NE(xml_error("<a><b></a></b>"), "");
  EXPECT_NE(xml_error("<a><b x=1/></a>"), "");
  EXPECT_NE(xml_error("<a/><b/>"), "");
  EXPECT_NE(xml_error("<a>"), "");
  EXPECT_NE(xml_error("<a><b x=\"1\" </a>"), "");
}

TEST_F(IoTest, SnapshotXmfReadableByH5py) {
  ASSERT_TRUE(have_h5py()) << "/usr/bin/python3 cannot import h5py: run scripts/setup.sh (it installs python3-h5py)";
  SnapshotSeries s(dir, "particles");
  write_particles(s, 0.0, 0, 7, 1);
  write_particles(s, 0.1, 10, 0, 2);
  write_particles(s, 0.2, 20, 3, 3);
  const std::string shape = run_python(
      dir, "import sys, h5py\nprint(h5py.File(sys.argv[1], 'r')['position'].shape)\n",
      (dir / "particles" / "particles_000000.h5").string());
  EXPECT_EQ(shape, "(7, 3)");
  EXPECT_EQ(run_python(dir, kXdmfCheck, s.xmf_path().string()), "OK 3");
}

// ------------------------------------------------------------------ grid series

namespace {
struct GridData {
  std::vector<double> phi, vmax, stress, count;
  std::vector<Vec3> u;
};
GridData make_grid(size_t nc, double seed) {
  GridData g;
  for (size_t c = 0; c < nc; ++c) {
    g.phi.push_back(seed + 0.01 * c);
    g.u.push_back({double(c), -double(c), seed});
    g.vmax.push_back(2.0 * c);
    for (int i = 0; i < 6; ++i) g.stress.push_back(10.0 * c + i);  // xx yy zz xy xz yz = +0..+5
    g.count.push_back(double(c % 3));
  }
  return g;
}
}  // namespace

TEST_F(IoTest, GridSeriesRoundTrip) {
  const GridSpec spec{{-1.0, 0.5, 2.0}, 0.25, 4, 3, 2};
  GridSeries gs(dir, "bed", spec);
  const GridData g0 = make_grid(spec.cells(), 0.0), g1 = make_grid(spec.cells(), 1.0);
  gs.write(0.5, g0.phi, g0.u, g0.vmax, g0.stress, g0.count);
  gs.write(1.5, g1.phi, g1.u, g1.vmax, g1.stress, g1.count);

  H5Reader r(dir / "grids" / "bed" / "bed_000001.h5");
  EXPECT_EQ(r.attr_double("/", "time"), 1.5);
  EXPECT_EQ(r.attr_double("/", "origin_x"), -1.0);
  EXPECT_EQ(r.attr_double("/", "origin_y"), 0.5);
  EXPECT_EQ(r.attr_double("/", "origin_z"), 2.0);
  EXPECT_EQ(r.attr_double("/", "h"), 0.25);
  EXPECT_EQ(r.attr_int64("/", "nx"), 4);
  EXPECT_EQ(r.attr_int64("/", "ny"), 3);
  EXPECT_EQ(r.attr_int64("/", "nz"), 2);
  EXPECT_EQ(r.shape("volume_fraction"), (std::vector<uint64_t>{2, 3, 4}));
  EXPECT_EQ(r.shape("mean_velocity"), (std::vector<uint64_t>{2, 3, 4, 3}));
  EXPECT_EQ(r.shape("stress"), (std::vector<uint64_t>{2, 3, 4, 6}));
  EXPECT_TRUE(bitwise_equal(r.read<double>("volume_fraction"), g1.phi));
  EXPECT_TRUE(bitwise_equal(r.read<double>("max_speed"), g1.vmax));
  EXPECT_TRUE(bitwise_equal(r.read<double>("count"), g1.count));
  const auto u = r.read<double>("mean_velocity");
  EXPECT_EQ(std::memcmp(u.data(), g1.u.data(), u.size() * sizeof(double)), 0);
  const auto st = r.read<double>("stress");  // XDMF order xx xy xz yy yz zz
  const std::vector<double> cell5(st.begin() + 30, st.begin() + 36);
  EXPECT_EQ(cell5, (std::vector<double>{50, 53, 54, 51, 55, 52}));
  EXPECT_EQ(r.attr_string("stress", "components"), "xx xy xz yy yz zz");

  EXPECT_EQ(slurp(dir / "grids" / "bed" / "times.csv"), "index,time\n0,0.5\n1,1.5\n");
  const std::string xmf = slurp(dir / "grids" / "bed.xmf");
  EXPECT_EQ(xml_error(xmf), "");
  EXPECT_EQ(count_of(xmf, "<Time Value="), 2);
  EXPECT_NE(xmf.find("Dimensions=\"3 4 5\""), std::string::npos);  // nodes, z y x
  EXPECT_NE(xmf.find(">2 0.5 -1</DataItem>"), std::string::npos);    // origin, z y x
  EXPECT_NE(xmf.find("bed/bed_000001.h5:/stress"), std::string::npos);
  EXPECT_NE(xmf.find("AttributeType=\"Tensor6\""), std::string::npos);
  EXPECT_EQ(count_temps(dir), 0);
}

TEST_F(IoTest, GridSeriesResumeAndValidation) {
  const GridSpec spec{{0, 0, 0}, 0.1, 2, 2, 2};
  const GridData g = make_grid(spec.cells(), 0.0);
  {
    GridSeries gs(dir, "box", spec);
    gs.write(1.0, g.phi, g.u, g.vmax, g.stress, g.count);
    EXPECT_THROW(gs.write(2.0, g.phi, g.u, g.vmax, std::vector<double>(5), g.count), std::invalid_argument);
    EXPECT_THROW(gs.write(2.0, std::vector<double>(7), g.u, g.vmax, g.stress, g.count), std::invalid_argument);
  }
  EXPECT_THROW(GridSeries(dir, "box", spec), std::runtime_error);
  EXPECT_THROW(GridSeries(dir, "box", GridSpec{{0, 0, 0}, 0.1, 2, 2, 3}, true), std::runtime_error);
  EXPECT_THROW(GridSeries(dir, "other", GridSpec{{0, 0, 0}, 0.0, 2, 2, 2}), std::invalid_argument);
  GridSeries gs(dir, "box", Vec3{0, 0, 0}, 0.1, 2, 2, 2, true);
  ASSERT_EQ(gs.size(), 1u);
  gs.write(2.0, g.phi, g.u, g.vmax, g.stress, g.count);
  gs.write(3.0, g.phi, g.u, g.vmax, g.stress, g.count);
  EXPECT_EQ(slurp(dir / "grids" / "box" / "times.csv"), "index,time\n0,1\n1,2\n2,3\n");
  EXPECT_EQ(count_of(slurp(gs.xmf_path()), "<Time Value="), 3);
}

TEST_F(IoTest, GridXmfReadableByH5py) {
  ASSERT_TRUE(have_h5py()) << "/usr/bin/python3 cannot import h5py: run scripts/setup.sh (it installs python3-h5py)";
  const GridSpec spec{{0, 0, 0}, 1.0, 3, 2, 1};
  GridSeries gs(dir, "g", spec);
  const GridData g = make_grid(spec.cells(), 0.0);
  gs.write(0.0, g.phi, g.u, g.vmax, g.stress, g.count);
  gs.write(1.0, g.phi, g.u, g.vmax, g.stress, g.count);
  EXPECT_EQ(run_python(dir, kXdmfCheck, gs.xmf_path().string()), "OK 2");
}
