#pragma once
// Who may write into a run folder. A run never reuses a folder that holds
// anything (a previous run's files would be overwritten before anything can
// refuse), and a folder is owned by one live launcher at a time: the launcher
// holds an flock on RUN_DIR/launcher.lock for its lifetime. The kernel
// releases the lock when the launcher dies, however it dies, so a lock left
// by a killed launcher is free.
#include <filesystem>
#include <memory>
#include <stdexcept>
#include <string>

namespace mlcg::launcher {

// The folder cannot be used; the message names it and what to do instead.
struct RunFolderError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// `mlcg run --out DIR`: DIR must be missing or an empty folder (a leftover launcher.lock alone counts as
// empty, as do the files `mlcg submit` puts there first: submission_file). Throws RunFolderError otherwise;
// writes nothing.
void check_new_run_folder(const std::filesystem::path& dir);

// The launcher's hold on a run folder: taken with LOCK_EX | LOCK_NB, released when this object
// (or the process) ends. The fd is close-on-exec: a child that outlives the launcher must not keep it.
class RunLock {
 public:
  // Throws RunFolderError naming the holder's pid when another live launcher holds the folder.
  explicit RunLock(const std::filesystem::path& run_dir);
  ~RunLock();
  RunLock(const RunLock&) = delete;
  RunLock& operator=(const RunLock&) = delete;

 private:
  int fd_ = -1;
};

inline constexpr const char* kLockFile = "launcher.lock";
// `mlcg submit`'s batch script in the run folder; Slurm writes the job's output beside it (slurm-<job id>.out).
inline constexpr const char* kSubmitScript = "mlcg_submit.sh";
// launcher.lock, mlcg_submit.sh and slurm-<digits>.out: files a folder may hold before its run starts.
bool submission_file(const std::string& name);

// `mlcg run --out DIR`: checks DIR (check_new_run_folder), creates it, locks it and checks it again
// under the lock (another launcher may have used it in between). Throws RunFolderError.
std::unique_ptr<RunLock> claim_new_run_folder(const std::filesystem::path& dir);

}  // namespace mlcg::launcher
