// File helpers shared by the snapshot formats (snapshot.cpp, snapshot_store.cpp): synced
// writes, the manifest's JSON, and publishing a snapshot folder with write-then-rename.
// Internal to protocol/snapshot.
#pragma once

#include <nlohmann/json.hpp>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "protocol/snapshot/snapshot.h"

namespace loam::snapshot_io {

// Creates or replaces `path` with `bytes` and fsyncs it.
Status write_file_synced(const std::string& path, std::span<const uint8_t> bytes);
nlohmann::json world_json(const WorldParams& p);
Result<WorldParams> world_from_json(const nlohmann::json& j, const std::string& path);
// The manifest fields both formats share.
nlohmann::json manifest_json(const SnapshotManifest& m, uint32_t format);
// Writes `files` (name, bytes) into <data>/snapshots/.tmp-snapshot-<id>, fsyncs them and the
// folder, renames it to snapshot-<id> (replacing one of that id) and fsyncs the parent.
// Returns the final path; on failure removes the temporary folder.
Result<std::string> publish(const std::string& data_dir, uint64_t snapshot_id,
                            const std::vector<std::pair<std::string, std::span<const uint8_t>>>& files);

}  // namespace loam::snapshot_io
