#include "server/cmd/command.h"

#include <filesystem>
#include <stdexcept>

#include "server/storage.h"

namespace loam::server::cmd {

void die(const Error& e) { throw std::runtime_error(e.describe()); }

std::vector<std::string> expand_logs(const std::vector<std::string>& args, std::string* data_dir) {
  if (args.size() == 1 && std::filesystem::is_directory(args[0])) {
    *data_dir = args[0];
    return list_segments(args[0]);
  }
  if (data_dir->empty() && !args.empty()) {
    // <data>/log/segment-*.loamlog: snapshots live two levels up.
    *data_dir = std::filesystem::path(args[0]).parent_path().parent_path().string();
  }
  return args;
}

}  // namespace loam::server::cmd
