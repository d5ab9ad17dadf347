// OutputFile (OutputFile.h), the one way Loom writes a file: whatever is planted at the path (a FIFO with or
// without a reader, a socket, a folder, a symbolic link, a hard link to a user's file) is refused by name or
// replaced by a new file, never written through, followed or waited on.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>

#include "TestDir.h"
#include "loom/cloth/Error.h"
#include "loom/cloth/OutputFile.h"

namespace loom {
namespace {

namespace fs = std::filesystem;
using loom::test::test_dir;

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// The message of the Error that opening `path` throws in `mode` ("" when it opens).
std::string refusal(const fs::path& path, OutputMode mode = OutputMode::kReplace) {
  try {
    OutputFile f(path.string(), mode);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(OutputFile, WritesReplacesAppendsAndPatches) {
  const fs::path p = test_dir() / "a.bin";
  {
    OutputFile f(p.string());
    f << "hello world";
    f.seekp(0);
    f << "J";
    f.close();
    EXPECT_TRUE(f);
  }
  EXPECT_EQ(slurp(p), "Jello world");
  { OutputFile(p.string()) << "new"; }
  EXPECT_EQ(slurp(p), "new");
  {
    OutputFile f(p.string(), std::ios::app);
    f << "er";
  }
  EXPECT_EQ(slurp(p), "newer");
  {
    OutputFile f(p.string(), OutputMode::kAppend);
    f.truncate(3);
    f << "t";
  }
  EXPECT_EQ(slurp(p), "newt");
}

// A write that fails says why: /dev/full refuses every write with ENOSPC, as a full disk does.
TEST(OutputFile, AFailedWriteKeepsItsReason) {
  const int fd = ::open("/dev/full", O_WRONLY | O_CLOEXEC);
  if (fd < 0) GTEST_SKIP() << "no /dev/full";
  FdStreamBuf buf(fd);
  std::ostream out(&buf);
  out << std::string(200000, 'x');  // past the buffer: written through
  EXPECT_TRUE(out.bad());
  buf.close();
  EXPECT_EQ(buf.error(), ENOSPC);
  EXPECT_NE(std::string(std::strerror(buf.error())).find("No space"), std::string::npos);
}

TEST(OutputFile, AFifoIsRefusedWithOrWithoutAReaderAndNeverBlocks) {
  const fs::path p = test_dir() / "fifo.obj";
  ASSERT_EQ(::mkfifo(p.c_str(), 0600), 0);
  for (const OutputMode mode : {OutputMode::kReplace, OutputMode::kAppend}) {
    EXPECT_NE(refusal(p, mode).find(p.string() + ": is a FIFO, not a regular file"), std::string::npos)
        << refusal(p, mode);
    const int reader = ::open(p.c_str(), O_RDONLY | O_NONBLOCK);  // a reader waiting on the FIFO
    ASSERT_GE(reader, 0);
    EXPECT_NE(refusal(p, mode).find("is a FIFO"), std::string::npos) << refusal(p, mode);
    ::close(reader);
  }
  EXPECT_TRUE(fs::is_fifo(fs::symlink_status(p)));  // left as it was
}

TEST(OutputFile, ASymbolicLinkIsRefusedAndItsTargetUntouched) {
  const fs::path dir = test_dir(), victim = dir / "victim.txt", link = dir / "frame.obj";
  std::ofstream(victim) << "precious";
  fs::create_symlink(victim, link);
  for (const OutputMode mode : {OutputMode::kReplace, OutputMode::kAppend})
    EXPECT_NE(refusal(link, mode).find(link.string() + ": is a symbolic link"), std::string::npos)
        << refusal(link, mode);
  fs::create_symlink(dir / "missing.txt", dir / "dangling.obj");  // a link to nothing: nothing created
  EXPECT_NE(refusal(dir / "dangling.obj").find("is a symbolic link"), std::string::npos);
  EXPECT_FALSE(fs::exists(dir / "missing.txt"));
  EXPECT_EQ(slurp(victim), "precious");
}

TEST(OutputFile, AFolderOrASocketIsRefusedByName) {
  const fs::path dir = test_dir();
  fs::create_directories(dir / "sub.obj");
  EXPECT_NE(refusal(dir / "sub.obj").find("is a folder"), std::string::npos) << refusal(dir / "sub.obj");
  const fs::path sock = dir / "s.csv";
  const int fd = ::socket(AF_UNIX, SOCK_STREAM, 0);
  ASSERT_GE(fd, 0);
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  ASSERT_LT(sock.string().size(), sizeof addr.sun_path);
  std::snprintf(addr.sun_path, sizeof addr.sun_path, "%s", sock.c_str());
  ASSERT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
  EXPECT_NE(refusal(sock).find("is a socket"), std::string::npos) << refusal(sock);
  ::close(fd);
  EXPECT_NE(refusal("/dev/null").find("is a device"), std::string::npos) << refusal("/dev/null");
  EXPECT_NE(refusal(dir / "none" / "x.obj").find("cannot write"), std::string::npos);
}

// A hard link planted at the path shares its contents with a user's file: the output is a new file, the
// user's file keeps its bytes.
TEST(OutputFile, AHardLinkIsReplacedNotWrittenThrough) {
  const fs::path dir = test_dir(), victim = dir / "victim.txt", out = dir / "stats.csv";
  std::ofstream(victim) << "precious";
  fs::create_hard_link(victim, out);
  { OutputFile(out.string()) << "frame,time\n"; }
  EXPECT_EQ(slurp(out), "frame,time\n");
  EXPECT_EQ(slurp(victim), "precious");
  write_file_atomically(out.string(), (dir / "stats.csv.tmp").string(), "again\n");
  EXPECT_EQ(slurp(out), "again\n");
  EXPECT_FALSE(fs::exists(dir / "stats.csv.tmp"));
}

TEST(OutputFile, AFifoAtTheTemporaryNameRefusesTheAtomicWrite) {
  const fs::path dir = test_dir();
  ASSERT_EQ(::mkfifo((dir / "summary.json.tmp").c_str(), 0600), 0);
  try {
    write_file_atomically((dir / "summary.json").string(), (dir / "summary.json.tmp").string(), "{}");
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find((dir / "summary.json.tmp").string() + ": is a FIFO"),
              std::string::npos)
        << e.what();
  }
  EXPECT_FALSE(fs::exists(dir / "summary.json"));
}

// Inside a registered output folder (OutputRoot), a folder on the way replaced by a symbolic link after it
// was made (the race a pre-flight check cannot close) is refused by name for every write: a new file, an
// append, an atomic write, a rename, a new folder and a removal; nothing reaches the link's target.
TEST(OutputRoot, AFolderOnTheWayReplacedByALinkIsNeverFollowed) {
  const fs::path dir = test_dir(), root = dir / "out", outside = dir / "outside";
  fs::create_directories(root);
  fs::create_directories(outside);
  std::ofstream(outside / "log.txt") << "user";
  const OutputRoot registered(root.string());
  make_output_folder((root / "render").string());
  { OutputFile((root / "render" / "frame_00000.png").string()) << "png"; }
  EXPECT_EQ(slurp(root / "render" / "frame_00000.png"), "png");
  fs::rename(root / "render", root / "render.moved");
  fs::create_directory_symlink(outside, root / "render");
  const std::string link = (root / "render").string() + ": is a symbolic link inside the output folder";
  auto expect_refused = [&](const char* what, const std::function<void()>& write) {
    try {
      write();
      ADD_FAILURE() << what << ": no error";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(link), std::string::npos) << what << ": " << e.what();
    }
  };
  expect_refused("new file", [&] { OutputFile((root / "render" / "frame_00001.png").string()); });
  expect_refused("append", [&] { OutputFile((root / "render" / "log.txt").string(), OutputMode::kAppend); });
  expect_refused("atomic", [&] {
    write_file_atomically((root / "render" / "a.json").string(), (root / "render" / "a.json.tmp").string(),
                          "{}");
  });
  expect_refused("folder", [&] { make_output_folder((root / "render" / "sub").string()); });
  std::ofstream(root / "stats.csv.partial") << "rows";
  expect_refused("rename", [&] {
    rename_output((root / "stats.csv.partial").string(), (root / "render" / "stats.csv").string());
  });
  EXPECT_FALSE(remove_output((root / "render" / "log.txt").string()));
  // The same path spelled with "." components is the same folder; ".." below it leaves it.
  expect_refused("dot", [&] { OutputFile((root / "." / "render" / "./x.png").string()); });
  try {
    OutputFile((root / ".." / "outside" / "x.png").string());
    ADD_FAILURE() << "no error for ..";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("leaves the output folder"), std::string::npos) << e.what();
  }
  EXPECT_EQ(slurp(outside / "log.txt"), "user");
  EXPECT_EQ(std::distance(fs::directory_iterator(outside), fs::directory_iterator()), 1);
  // The link itself is removed, never its target.
  EXPECT_TRUE(remove_output((root / "render").string()));
  EXPECT_TRUE(fs::exists(outside / "log.txt"));
}

// The folder itself renamed away and replaced by a link while it is registered: writes still go into the
// folder that was opened (now under its new name), never into the link's target.
TEST(OutputRoot, TheFolderReplacedByALinkIsNotFollowed) {
  const fs::path dir = test_dir(), root = dir / "out", outside = dir / "outside";
  fs::create_directories(root);
  fs::create_directories(outside);
  const OutputRoot registered(root.string());
  fs::rename(root, dir / "moved");
  fs::create_directory_symlink(outside, root);
  { OutputFile((root / "summary.json").string()) << "{}"; }
  EXPECT_FALSE(fs::exists(outside / "summary.json"));
  EXPECT_EQ(slurp(dir / "moved" / "summary.json"), "{}");
}

// A hard-linked file is never appended to: the other name's file would change.
TEST(OutputFile, AnAppendToAHardLinkIsRefused) {
  const fs::path dir = test_dir(), victim = dir / "victim.txt", log = dir / ".loom-manifest";
  std::ofstream(victim) << "precious";
  fs::create_hard_link(victim, log);
  EXPECT_NE(refusal(log, OutputMode::kAppend).find(log.string() + ": is a hard link (2 names"),
            std::string::npos)
      << refusal(log, OutputMode::kAppend);
  EXPECT_EQ(slurp(victim), "precious");
}

}  // namespace
}  // namespace loom
