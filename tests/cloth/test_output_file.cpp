// OutputFile (OutputFile.h), the one way Loom writes a file: whatever is planted at the path (a FIFO with or
// without a reader, a socket, a folder, a symbolic link, a hard link to a user's file) is refused by name or
// replaced by a new file, never written through, followed or waited on.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
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

}  // namespace
}  // namespace loom
