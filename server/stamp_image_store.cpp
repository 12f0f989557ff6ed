#include "server/stamp_image_store.h"

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <filesystem>

#include "protocol/log/log_file.h"
#include "protocol/snapshot/snapshot.h"
#include "protocol/snapshot/stamp_image_file.h"

namespace loam::server {
namespace fs = std::filesystem;

namespace {

std::string file_name(uint64_t id) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%016llx.loamimg", (unsigned long long)id);
  return buf;
}

}  // namespace

Result<size_t> store_stamp_images(const std::string& data_dir, const TextureRegistry& registry) {
  const fs::path dir = fs::path(data_dir) / "images";
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) return make_error(ErrorCode::kIo, dir.string(), "cannot create: " + ec.message());
  size_t written = 0;
  for (const StampTexture* t : registry.all()) {
    const fs::path final_path = dir / file_name(t->id);
    if (fs::exists(final_path, ec)) continue;  // content-addressed: the same bytes
    const fs::path tmp = dir / (".tmp-" + file_name(t->id));
    const std::vector<uint8_t> bytes = encode_stamp_image(*t);
    const Status st = [&]() -> Status {
      std::FILE* f = std::fopen(tmp.c_str(), "wb");
      if (!f) return make_error(ErrorCode::kIo, tmp.string(), "cannot create");
      const bool ok = std::fwrite(bytes.data(), 1, bytes.size(), f) == bytes.size() && std::fflush(f) == 0;
      std::fclose(f);
      if (!ok) return make_error(ErrorCode::kIo, tmp.string(), "write failed");
      LOAM_TRY(fsync_path(tmp.string()));
      fs::rename(tmp, final_path, ec);
      if (ec) return make_error(ErrorCode::kIo, final_path.string(), "rename failed: " + ec.message());
      return fsync_path(dir.string());
    }();
    if (!st.ok()) {
      fs::remove(tmp, ec);
      return st.error();
    }
    ++written;
  }
  return written;
}

LoadedImages load_stamp_images(const std::string& data_dir, TextureRegistry& registry) {
  LoadedImages out;
  const fs::path dir = fs::path(data_dir) / "images";
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return out;
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    if (e.path().extension() == ".loamimg" && e.path().filename().string()[0] != '.')
      files.push_back(e.path());
  }
  std::sort(files.begin(), files.end());
  const uint64_t kMaxFileBytes = max_stamp_image_file_bytes();
  for (const fs::path& f : files) {
    auto bytes = log::read_file(f.string(), kMaxFileBytes);
    if (!bytes) {
      out.damaged.push_back(bytes.error().describe());
      continue;
    }
    auto t = decode_stamp_image(*bytes, f.string());
    if (!t) {
      out.damaged.push_back(t.error().describe());
      continue;
    }
    if (f.filename().string() != file_name(t->id)) {
      out.damaged.push_back(f.string() + ": content does not match the id in its name");
      continue;
    }
    auto id = registry.add(t->width, t->height, t->samples);
    if (!id) {
      out.damaged.push_back(f.string() + ": " + id.error().describe());
      continue;
    }
    ++out.loaded;
  }
  return out;
}

}  // namespace loam::server
