#include "parallel/comm.hpp"

#include <cstring>
#include <stdexcept>

namespace mlcg {

Comm::Comm() : Comm(false) {}

Comm::Comm(bool self) {
  int init = 0, fin = 0;
  MPI_Initialized(&init);
  MPI_Finalized(&fin);
  if (init && !fin && !self) {
    comm_ = MPI_COMM_WORLD;
    MPI_Comm_rank(comm_, &rank_);
    MPI_Comm_size(comm_, &size_);
  }
}

double Comm::sum(double v) const {
  if (serial()) return v;
  double r = 0.0;
  MPI_Allreduce(&v, &r, 1, MPI_DOUBLE, MPI_SUM, comm_);
  return r;
}

int64_t Comm::sum(int64_t v) const {
  if (serial()) return v;
  int64_t r = 0;
  MPI_Allreduce(&v, &r, 1, MPI_INT64_T, MPI_SUM, comm_);
  return r;
}

double Comm::max(double v) const {
  if (serial()) return v;
  double r = 0.0;
  MPI_Allreduce(&v, &r, 1, MPI_DOUBLE, MPI_MAX, comm_);
  return r;
}

bool Comm::any(bool v) const {
  if (serial()) return v;
  int in = v ? 1 : 0, out = 0;
  MPI_Allreduce(&in, &out, 1, MPI_INT, MPI_LOR, comm_);
  return out != 0;
}

void Comm::sum_in_place(double* a, size_t n) const {
  if (!serial() && n > 0) MPI_Allreduce(MPI_IN_PLACE, a, static_cast<int>(n), MPI_DOUBLE, MPI_SUM, comm_);
}

void Comm::sum_in_place(int64_t* a, size_t n) const {
  if (!serial() && n > 0) MPI_Allreduce(MPI_IN_PLACE, a, static_cast<int>(n), MPI_INT64_T, MPI_SUM, comm_);
}

void Comm::max_in_place(double* a, size_t n) const {
  if (!serial() && n > 0) MPI_Allreduce(MPI_IN_PLACE, a, static_cast<int>(n), MPI_DOUBLE, MPI_MAX, comm_);
}

std::pair<double, int> Comm::max_loc(double v) const {
  if (serial()) return {v, 0};
  struct { double v; int r; } in{v, rank_}, out{};
  MPI_Allreduce(&in, &out, 1, MPI_DOUBLE_INT, MPI_MAXLOC, comm_);
  return {out.v, out.r};
}

std::vector<std::vector<char>> Comm::alltoall(const std::vector<std::vector<char>>& send) const {
  if (serial()) return {send.empty() ? std::vector<char>{} : send[0]};
  const auto n = static_cast<size_t>(size_);
  std::vector<int> scount(n), rcount(n), sdisp(n), rdisp(n);
  std::vector<char> sbuf;
  for (size_t r = 0; r < n; ++r) {
    scount[r] = static_cast<int>(send[r].size());
    sdisp[r] = static_cast<int>(sbuf.size());
    sbuf.insert(sbuf.end(), send[r].begin(), send[r].end());
  }
  MPI_Alltoall(scount.data(), 1, MPI_INT, rcount.data(), 1, MPI_INT, comm_);
  int total = 0;
  for (size_t r = 0; r < n; ++r) {
    rdisp[r] = total;
    total += rcount[r];
  }
  std::vector<char> rbuf(static_cast<size_t>(total));
  MPI_Alltoallv(sbuf.data(), scount.data(), sdisp.data(), MPI_CHAR, rbuf.data(), rcount.data(), rdisp.data(),
                MPI_CHAR, comm_);
  std::vector<std::vector<char>> recv(n);
  for (size_t r = 0; r < n; ++r)
    recv[r].assign(rbuf.begin() + rdisp[r], rbuf.begin() + rdisp[r] + rcount[r]);
  return recv;
}

std::vector<char> Comm::allgather(const std::vector<char>& mine) const {
  if (serial()) return mine;
  const auto n = static_cast<size_t>(size_);
  int count = static_cast<int>(mine.size());
  std::vector<int> counts(n), disp(n);
  MPI_Allgather(&count, 1, MPI_INT, counts.data(), 1, MPI_INT, comm_);
  int total = 0;
  for (size_t r = 0; r < n; ++r) {
    disp[r] = total;
    total += counts[r];
  }
  std::vector<char> all(static_cast<size_t>(total));
  MPI_Allgatherv(mine.data(), count, MPI_CHAR, all.data(), counts.data(), disp.data(), MPI_CHAR, comm_);
  return all;
}

std::vector<char> Comm::gather0(const std::vector<char>& mine) const {
  if (serial()) return mine;
  const auto n = static_cast<size_t>(size_);
  int count = static_cast<int>(mine.size());
  std::vector<int> counts(n), disp(n);
  MPI_Gather(&count, 1, MPI_INT, counts.data(), 1, MPI_INT, 0, comm_);
  int total = 0;
  for (size_t r = 0; r < n; ++r) {
    disp[r] = total;
    total += counts[r];
  }
  std::vector<char> all(rank_ == 0 ? static_cast<size_t>(total) : 0);
  MPI_Gatherv(mine.data(), count, MPI_CHAR, all.data(), counts.data(), disp.data(), MPI_CHAR, 0, comm_);
  return all;
}

std::string Comm::bcast(const std::string& s, int root) const {
  if (serial()) return s;
  int n = static_cast<int>(s.size());
  MPI_Bcast(&n, 1, MPI_INT, root, comm_);
  std::string out = rank_ == root ? s : std::string(static_cast<size_t>(n), '\0');
  MPI_Bcast(out.data(), n, MPI_CHAR, root, comm_);
  return out;
}

void Comm::exchange(const std::vector<int>& peers, const std::vector<std::vector<double>>& send,
                    std::vector<std::vector<double>>& recv) const {
  if (peers.empty()) return;
  std::vector<MPI_Request> req(2 * peers.size());
  for (size_t k = 0; k < peers.size(); ++k)
    MPI_Irecv(recv[k].data(), static_cast<int>(recv[k].size()), MPI_DOUBLE, peers[k], 7, comm_, &req[k]);
  for (size_t k = 0; k < peers.size(); ++k)
    MPI_Isend(send[k].data(), static_cast<int>(send[k].size()), MPI_DOUBLE, peers[k], 7, comm_,
              &req[peers.size() + k]);
  MPI_Waitall(static_cast<int>(req.size()), req.data(), MPI_STATUSES_IGNORE);
}

void ByteReader::copy(void* dst, size_t n) {
  // Compared as sizes: forming p_ + n beyond the buffer's end is itself undefined.
  if (n > static_cast<size_t>(end_ - p_)) throw std::runtime_error("ByteReader: buffer ends early (corrupt exchange)");
  // memcpy needs valid pointers even for 0 bytes; an empty vector's data() (no contacts) may be null.
  if (n == 0) return;
  std::memcpy(dst, p_, n);
  p_ += n;
}

}  // namespace mlcg
