// The session's texture-stamp images, kept in its data folder (<data>/images/<id>.loamimg) so
// that what a logged texture stamp means never depends on the --stamp-image options of the
// process that reads the log: recovery and replay register every stored image.
//
// The bytes are protocol/snapshot/stamp_image_file.h. Written to a temporary name, fsynced and
// renamed before the server accepts any stamp. Reading is safe on untrusted files: the file
// size is capped before reading, the checksum and the content id (the file's name) are
// verified, and every failure is reported naming the file.
#pragma once

#include <string>
#include <vector>

#include "protocol/result.h"
#include "protocol/stamps/texture_registry.h"

namespace loam::server {

// Stores every image of `registry` that the folder does not hold yet. Returns how many it wrote.
Result<size_t> store_stamp_images(const std::string& data_dir, const TextureRegistry& registry);

struct LoadedImages {
  size_t loaded = 0;
  std::vector<std::string> damaged;  // files that failed to read, with why (not registered)
};
// Registers every image stored under <data_dir>/images. A damaged file is reported, not
// fatal: a texture stamp that needs it then fails to apply, and that error names the record.
LoadedImages load_stamp_images(const std::string& data_dir, TextureRegistry& registry);

}  // namespace loam::server
