// loam-server log dump|summary|repair: human views of a deformation log (JSON lines, a
// summary), and the operator's cut of a damaged tail at the offset `log dump` reported.
#include <cstdio>
#include <memory>

#include "protocol/log/log_file.h"
#include "protocol/log/log_json.h"
#include "server/cmd/command.h"

namespace loam::server::cmd {

namespace {

struct LogOptions {
  std::vector<std::string> logs;
  bool summary_json = false, allow_damaged = false;
  std::string repair_segment;
  uint64_t repair_offset = 0;
};

// dump and summary: every readable segment is shown; an unreadable or damaged one is reported
// and makes the exit kExitDamaged unless --allow-damaged.
int view(const LogOptions& o, bool dump) {
  std::string dir;
  const auto segs = expand_logs(o.logs, &dir);
  std::vector<log::SegmentScan> scans;
  std::vector<std::string> damaged;
  for (const std::string& s : segs) {
    auto scan = log::read_segment(s);
    if (!scan) {
      damaged.push_back(scan.error().describe());
      continue;
    }
    if (scan->tail_error) damaged.push_back(s + ": " + scan->tail_error->describe());
    scans.push_back(std::move(*scan));
  }
  if (dump) {
    for (const auto& s : scans) std::fputs(log::dump_jsonl(s).c_str(), stdout);
  } else {
    const auto sum = log::summarize(scans);
    std::fputs((o.summary_json ? log::summary_to_json(sum) : log::summary_to_text(sum)).c_str(), stdout);
  }
  for (const std::string& d : damaged) std::fprintf(stderr, "loam-server: damaged: %s\n", d.c_str());
  if (!damaged.empty() && !o.allow_damaged) return kExitDamaged;
  return 0;
}

int repair(const LogOptions& o) {
  std::string dir;
  auto segs = expand_logs({o.repair_segment}, &dir);
  if (segs.empty()) die(make_error(ErrorCode::kNotFound, o.repair_segment, "no log segments"));
  const std::string& seg = segs.back();
  auto scan = log::read_segment(seg);
  if (!scan) die(scan.error());
  if (!scan->tail_error) {
    std::printf("%s: clean, nothing to repair\n", seg.c_str());
    return 0;
  }
  if (scan->damage_offset != o.repair_offset) {
    die(make_error(ErrorCode::kInvalidArgument, "--at",
                   seg + " is damaged at byte offset " + std::to_string(scan->damage_offset) + ", not " +
                       std::to_string(o.repair_offset) + " (" + scan->tail_error->describe() + ")"));
  }
  auto bytes = log::read_file(seg);
  if (!bytes) die(bytes.error());
  const uint64_t dropped = bytes->size() - scan->good_bytes;
  const auto cut = log::truncate_segment(seg, scan->good_bytes);
  if (!cut.ok()) die(cut.error());
  std::printf(
      "%s: cut at byte offset %zu: dropped %llu bytes (at most %llu records) after sequence %llu (%s)\n",
      seg.c_str(), scan->good_bytes, (unsigned long long)dropped,
      (unsigned long long)((dropped + log::kRecordOverheadBytes + log::kStampRecordBodyBytes - 1) /
                           (log::kRecordOverheadBytes + log::kStampRecordBodyBytes)),
      (unsigned long long)scan->last_seq(), scan->tail_error->describe().c_str());
  return 0;
}

}  // namespace

Command add_log(CLI::App& app) {
  auto o = std::make_shared<LogOptions>();
  auto* log_cmd = app.add_subcommand("log", "Human views of a deformation log");
  log_cmd->require_subcommand(1);
  auto* dump_cmd = log_cmd->add_subcommand("dump", "Print header and records as JSON lines");
  dump_cmd->add_option("logs", o->logs, "Segment files or a data folder")->required();
  auto* summary_cmd = log_cmd->add_subcommand("summary", "Records, sequence range, kinds, time");
  summary_cmd->add_option("logs", o->logs, "Segment files or a data folder")->required();
  summary_cmd->add_flag("--json", o->summary_json, "Print JSON instead of text");
  for (auto* c : {dump_cmd, summary_cmd}) {
    c->add_flag("--allow-damaged", o->allow_damaged,
                "Exit 0 even when a segment is damaged (default: exit 3)");
  }
  auto* repair_cmd = log_cmd->add_subcommand(
      "repair", "Cut the last segment at its damage (drops the damaged record and everything after it)");
  repair_cmd->add_option("segment", o->repair_segment, "Segment file, or a data folder (its last segment)")
      ->required();
  repair_cmd
      ->add_option("--at", o->repair_offset,
                   "The damage's byte offset, as `log dump` reports it (required: confirms what is dropped)")
      ->required();
  return {log_cmd, [o, dump_cmd, summary_cmd, repair_cmd]() -> int {
            if (*dump_cmd || *summary_cmd) return view(*o, bool(*dump_cmd));
            if (*repair_cmd) return repair(*o);
            return 0;
          }};
}

}  // namespace loam::server::cmd
