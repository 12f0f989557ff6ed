// The client's folders are its libraries (README, "How it fits together"): each folder under
// client/ is one CMake library in a namespace of the folder's name, the folders without GL
// include no folder with GL, and the README's folder map names every folder with the library
// client/CMakeLists.txt builds from it.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

namespace {

namespace fs = std::filesystem;

const fs::path kRoot = LOAM_SOURCE_DIR;

std::string read_text(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// The project paths a file includes ("client/lod/x.h" -> "client/lod").
std::set<std::string> included_folders(const fs::path& file) {
  std::set<std::string> out;
  std::istringstream in(read_text(file));
  for (std::string line; std::getline(in, line);) {
    const std::string tag = "#include \"";
    if (line.rfind(tag, 0) != 0) continue;
    const std::string path = line.substr(tag.size(), line.find('"', tag.size()) - tag.size());
    const size_t slash = path.rfind('/');
    if (slash != std::string::npos) out.insert(path.substr(0, slash));
  }
  return out;
}

// Which folders each client folder may include, besides itself and protocol/ (the contract).
const std::map<std::string, std::set<std::string>> kAllowed = {
    {"net", {"transport"}},
    {"scene", {}},
    {"lod", {"client/scene"}},
    {"query", {}},
    {"terrain", {"client/net", "client/scene", "client/query", "gpu"}},
    {"controls", {"client/scene", "client/query", "client/terrain"}},
};

// gpu/ headers a folder without GL may use: plain data, no GL.
const std::set<std::string> kGpuDataHeaders = {"gpu/stamp_results.h"};

TEST(ClientFolders, FoldersWithoutGlIncludeOnlyTheFoldersBelowThem) {
  for (const auto& [folder, allowed] : kAllowed) {
    const fs::path dir = kRoot / "client" / folder;
    ASSERT_TRUE(fs::is_directory(dir)) << dir;
    for (const auto& entry : fs::directory_iterator(dir)) {
      const fs::path file = entry.path();
      for (const std::string& inc : included_folders(file)) {
        if (inc == "client/" + folder || inc.rfind("protocol", 0) == 0) continue;
        EXPECT_TRUE(allowed.count(inc)) << file.filename() << " in client/" << folder << " includes " << inc;
      }
      // Within gpu/, only plain data.
      std::istringstream in(read_text(file));
      for (std::string line; std::getline(in, line);) {
        if (line.rfind("#include \"gpu/", 0) != 0) continue;
        const std::string header = line.substr(10, line.find('"', 10) - 10);
        EXPECT_TRUE(kGpuDataHeaders.count(header)) << file << " includes " << header;
      }
      EXPECT_EQ(read_text(file).find("<epoxy/"), std::string::npos) << file << " uses GL";
    }
  }
}

TEST(ClientFolders, TheLodFolderIncludesNothingOfTheRenderer) {
  for (const auto& entry : fs::directory_iterator(kRoot / "client" / "lod")) {
    for (const std::string& inc : included_folders(entry.path()))
      EXPECT_NE(inc, "client/render") << entry.path().filename();
  }
}

TEST(ClientFolders, EveryFolderIsOneLibraryThatTheReadmesMapNames) {
  // client/CMakeLists.txt: loam_client_folder_library(NAME FOLDER), one per folder.
  const std::string cmake = read_text(kRoot / "client" / "CMakeLists.txt");
  std::map<std::string, std::string> library_of;
  const std::string call = "loam_client_folder_library(";
  for (size_t at = cmake.find(call); at != std::string::npos; at = cmake.find(call, at + 1)) {
    if (at >= 9 && cmake.compare(at - 9, 9, "function(") == 0) continue;  // the definition
    const size_t open = at + call.size();
    const std::string args = cmake.substr(open, cmake.find(')', open) - open);
    const size_t space = args.find(' ');
    if (space == std::string::npos) continue;
    const std::string folder = args.substr(space + 1);
    EXPECT_FALSE(library_of.count(folder)) << "client/" << folder << " is built into two libraries";
    library_of[folder] = args.substr(0, space);
  }
  // Every folder with sources is one (lib/ is the game library, include/ its headers).
  const std::string readme = read_text(kRoot / "README.md");
  for (const auto& entry : fs::directory_iterator(kRoot / "client")) {
    if (!entry.is_directory()) continue;
    const std::string folder = entry.path().filename().string();
    if (folder == "lib" || folder == "include") continue;
    ASSERT_TRUE(library_of.count(folder)) << "client/" << folder << " is no library of its own";
    const std::string row = "| `client/" + folder + "` | `" + library_of[folder] + "` |";
    EXPECT_NE(readme.find(row), std::string::npos) << "README's folder map lacks: " << row;
  }
  EXPECT_NE(readme.find("| `client/lib` | `libloam_client.so` |"), std::string::npos);
}

// A folder's code is in its namespace (loam::scene for client/scene, ...); net/ keeps the
// client's own (loam::client) and lib/ the game library's (loam::game).
TEST(ClientFolders, EachLibrarysCodeIsInTheNamespaceOfItsFolder) {
  for (const char* folder : {"scene", "lod", "query", "terrain", "controls", "render", "view"}) {
    for (const auto& entry : fs::directory_iterator(kRoot / "client" / folder)) {
      const std::string text = read_text(entry.path());
      EXPECT_NE(text.find("\nnamespace loam::" + std::string(folder) + " {"), std::string::npos)
          << entry.path().filename() << " in client/" << folder;
    }
  }
}

}  // namespace
