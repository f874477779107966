// Atomic writes: temporary name keeps the extension, nothing partial is left on failure, and a
// full disk (simulated with RLIMIT_FSIZE in a child process) gives a clear error and no file.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include "io/atomic_file.h"
#include "io/io_test_util.h"
#include "io/surface_io.h"
#include "io/volume_io.h"

using namespace authalic;
using namespace authalic::io;
using namespace authalic::test;

TEST(AtomicFile, TemporaryKeepsExtensionAndIsInSameFolder) {
  const std::string dir = temp_dir("atomic_ext");
  std::string seen;
  write_atomically(dir + "/out.surf.gii", [&](const std::string& tmp) {
    seen = tmp;
    write_bytes(tmp, "x");
  });
  EXPECT_EQ(std::filesystem::path(seen).parent_path(), std::filesystem::path(dir));
  EXPECT_TRUE(seen.size() > 9 && seen.substr(seen.size() - 9) == ".surf.gii") << seen;
  EXPECT_EQ(read_bytes(dir + "/out.surf.gii"), "x");
  EXPECT_EQ(list_dir(dir), std::vector<std::string>{"out.surf.gii"});
}

TEST(AtomicFile, FailureKeepsOldFileAndRemovesTemporary) {
  const std::string dir = temp_dir("atomic_fail");
  write_file_atomically(dir + "/a.txt", "old");
  try {
    write_atomically(dir + "/a.txt", [&](const std::string& tmp) {
      write_bytes(tmp, "half");
      throw std::runtime_error("simulated failure");
    });
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(dir + "/a.txt"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("simulated failure"), std::string::npos) << e.what();
  }
  EXPECT_EQ(read_bytes(dir + "/a.txt"), "old");
  EXPECT_EQ(list_dir(dir), std::vector<std::string>{"a.txt"});
}

TEST(AtomicFile, MissingFolderIsAClearError) {
  EXPECT_THROW(write_file_atomically("/nonexistent-authalic-dir/x.txt", "x"), std::runtime_error);
}

// Runs `write` in a child whose files may not exceed `limit` bytes (a full disk as the writer
// sees it: write() fails with EFBIG). Returns the child's message, or "" if it did not throw.
static std::string run_with_file_size_limit(rlim_t limit, const std::function<void()>& write) {
  int pipefd[2];
  if (::pipe(pipefd) != 0) return "pipe failed";
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::close(pipefd[0]);
    ::signal(SIGXFSZ, SIG_IGN);
    rlimit rl{limit, limit};
    ::setrlimit(RLIMIT_FSIZE, &rl);
    std::string msg = "NO ERROR";
    try {
      write();
    } catch (const std::exception& e) {
      msg = e.what();
    }
    if (::write(pipefd[1], msg.data(), msg.size()) < 0) _exit(2);
    _exit(0);
  }
  ::close(pipefd[1]);
  std::string msg;
  char buf[512];
  ssize_t n;
  while ((n = ::read(pipefd[0], buf, sizeof(buf))) > 0) msg.append(buf, static_cast<std::size_t>(n));
  ::close(pipefd[0]);
  int status = 0;
  ::waitpid(pid, &status, 0);
  return msg;
}

TEST(AtomicFile, DiskFullGivesClearErrorAndNoFile) {
  const std::string dir = temp_dir("atomic_full");
  const std::string big(1 << 20, 'x');
  const std::string msg = run_with_file_size_limit(64 * 1024, [&] { write_file_atomically(dir + "/big.bin", big); });
  EXPECT_NE(msg.find(dir + "/big.bin"), std::string::npos) << msg;
  EXPECT_NE(msg.find("too large"), std::string::npos) << msg;
  EXPECT_TRUE(list_dir(dir).empty()) << "left behind: " << list_dir(dir).size();

  // Library writers too: gifticlib and nifti-clib ignore write errors, ours verify after writing.
  TriMesh m = octahedron();
  for (int r = 0; r < 9; ++r) {
    TriMesh t;
    t.V.resize(m.V.rows() * 2, 3);
    t.V << m.V, m.V.array() + 50.0;
    t.F.resize(m.F.rows() * 2, 3);
    t.F << m.F, m.F.array() + static_cast<int>(m.V.rows());
    m = t;
  }
  for (const std::string name : {"/s.surf.gii", "/s.surf.gii.gz", "/s.vtk", "/lh.s"}) {
    const std::string gmsg = run_with_file_size_limit(512, [&] { write_surface(dir + name, m); });
    EXPECT_NE(gmsg.find(dir + name), std::string::npos) << name << ": " << gmsg;
    EXPECT_TRUE(list_dir(dir).empty()) << name << " left files behind";
  }
  Volume v;
  v.dims = {40, 40, 40};
  v.data.resize(v.num_voxels());
  for (std::size_t i = 0; i < v.data.size(); ++i) v.data[i] = static_cast<float>((i * 2654435761u) % 1000u);
  for (const std::string name : {"/v.nii", "/v.nii.gz", "/v.mgz"}) {
    const std::string vmsg = run_with_file_size_limit(512, [&] {
      if (name == "/v.mgz") write_mgh(dir + name, v);
      else write_nifti(dir + name, v);
    });
    EXPECT_NE(vmsg.find(dir + name), std::string::npos) << name << ": " << vmsg;
    EXPECT_TRUE(list_dir(dir).empty()) << name << " left files behind";
  }
}
