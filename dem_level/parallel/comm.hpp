#pragma once
// The level's communicator. Wraps MPI_COMM_WORLD when MPI is initialised and
// falls back to a serial communicator (one rank, no MPI calls) otherwise, so
// unit tests and tools can run a level without mpirun.
#include <mpi.h>

#include <cstdint>
#include <string>
#include <vector>

namespace mlcg {

class Comm {
 public:
  Comm();
  // self = true: a one-rank communicator even inside an MPI job (MPI_COMM_SELF).
  explicit Comm(bool self);
  int rank() const { return rank_; }
  int size() const { return size_; }
  bool serial() const { return size_ == 1; }

  double sum(double v) const;
  int64_t sum(int64_t v) const;
  double max(double v) const;
  bool any(bool v) const;
  void sum_in_place(double* a, size_t n) const;
  void sum_in_place(int64_t* a, size_t n) const;
  void max_in_place(double* a, size_t n) const;
  // Largest value over ranks and the lowest rank holding it.
  std::pair<double, int> max_loc(double v) const;

  // Every rank sends send[r] to rank r and receives recv[r] from rank r.
  std::vector<std::vector<char>> alltoall(const std::vector<std::vector<char>>& send) const;
  // Concatenation of every rank's buffer in rank order, on every rank.
  std::vector<char> allgather(const std::vector<char>& mine) const;
  // Same, on rank 0 only (other ranks get an empty vector).
  std::vector<char> gather0(const std::vector<char>& mine) const;
  std::string bcast(const std::string& s, int root) const;

  // Point-to-point exchange of doubles with peers; sizes known on both sides.
  void exchange(const std::vector<int>& peers, const std::vector<std::vector<double>>& send,
                std::vector<std::vector<double>>& recv) const;

 private:
  int rank_ = 0, size_ = 1;
  MPI_Comm comm_ = MPI_COMM_NULL;
};

// Appending and reading plain values in a byte buffer (migration, gathers).
class ByteWriter {
 public:
  explicit ByteWriter(std::vector<char>& b) : b_(b) {}
  template <class T>
  void put(const T& v) {
    const char* p = reinterpret_cast<const char*>(&v);
    b_.insert(b_.end(), p, p + sizeof(T));
  }
  template <class T>
  void put_n(const T* v, size_t n) {
    const char* p = reinterpret_cast<const char*>(v);
    b_.insert(b_.end(), p, p + n * sizeof(T));
  }

 private:
  std::vector<char>& b_;
};

class ByteReader {
 public:
  ByteReader(const char* p, size_t n) : p_(p), end_(p + n) {}
  explicit ByteReader(const std::vector<char>& b) : ByteReader(b.data(), b.size()) {}
  template <class T>
  T get() {
    T v;
    copy(&v, sizeof(T));
    return v;
  }
  template <class T>
  void get_n(T* v, size_t n) { copy(v, n * sizeof(T)); }
  bool done() const { return p_ >= end_; }

 private:
  void copy(void* dst, size_t n);
  const char* p_;
  const char* end_;
};

}  // namespace mlcg
