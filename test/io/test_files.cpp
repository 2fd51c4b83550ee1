// The one atomic writer of the C++ tools (io::AtomicFile, io::writeFilesAtomic).
#include <gtest/gtest.h>

#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "rbpf_slam/io/files.h"
#include "io/temp_files.h"

using rbpf_slam::io::AtomicFile;
using rbpf_slam::io::writeFileAtomic;
using rbpf_slam::io::writeFilesAtomic;

using temp_files::listDir;
using temp_files::readFile;

namespace
{
bool exists(const std::string& path)
{
  return std::ifstream(path).good();
}
}  // namespace

TEST(AtomicFile, CommitRenamesTheTemporaryIntoPlace)
{
  const std::string dir = temp_files::makeDir("rbpf_files"), path = dir + "/out.bag";
  {
    AtomicFile out(path);
    EXPECT_EQ(out.path(), path);
    EXPECT_NE(out.temporary(), path);
    EXPECT_EQ(out.temporary().rfind(dir + "/", 0), 0u) << "the temporary must be in the same folder";
    std::ofstream(out.temporary()) << "complete";
    EXPECT_FALSE(exists(path)) << "nothing at the path before commit()";
    out.commit();
  }
  EXPECT_EQ(readFile(path), "complete");
  EXPECT_EQ(listDir(dir), std::vector<std::string>{ "out.bag" });
}

TEST(AtomicFile, WithoutCommitTheTemporaryGoesAndTheOldFileStays)
{
  const std::string dir = temp_files::makeDir("rbpf_files"), path = dir + "/out.bag";
  std::ofstream(path) << "old";
  try
  {
    AtomicFile out(path);
    std::ofstream(out.temporary()) << "half";
    throw std::runtime_error("interrupted");  // as a recording that stops half-way
  }
  catch (const std::runtime_error&)
  {
  }
  EXPECT_EQ(readFile(path), "old");
  EXPECT_EQ(listDir(dir), std::vector<std::string>{ "out.bag" });
}

TEST(AtomicFile, CommitWithoutAWrittenFileNamesThePath)
{
  const std::string dir = temp_files::makeDir("rbpf_files"), path = dir + "/never.bag";
  AtomicFile out(path);
  try
  {
    out.commit();
    FAIL() << "commit() of a temporary never written must throw";
  }
  catch (const std::runtime_error& e)
  {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
  EXPECT_TRUE(listDir(dir).empty());
}

TEST(WriteFilesAtomic, AFailedFileLeavesNoneOfThem)
{
  const std::string dir = temp_files::makeDir("rbpf_files");
  writeFileAtomic(dir + "/a.txt", "old a");
  try
  {
    writeFilesAtomic({ { dir + "/a.txt", "new a" }, { dir + "/missing/b.txt", "b" } });
    FAIL() << "a file in a missing folder must throw";
  }
  catch (const std::runtime_error& e)
  {
    EXPECT_NE(std::string(e.what()).find("missing/b.txt"), std::string::npos) << e.what();
  }
  EXPECT_EQ(readFile(dir + "/a.txt"), "old a") << "no file is renamed when one fails";
  EXPECT_EQ(listDir(dir), std::vector<std::string>{ "a.txt" }) << "no temporary left behind";
  writeFilesAtomic({ { dir + "/a.txt", "new a" }, { dir + "/b.txt", "b" } });
  EXPECT_EQ(readFile(dir + "/a.txt"), "new a");
  EXPECT_EQ(readFile(dir + "/b.txt"), "b");
}
