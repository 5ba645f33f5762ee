#pragma once
// series.pvd: the ParaView collection that lists every snapshot with its time.
//
// The whole file is rewritten (atomically) after each addition, so it is complete at any
// moment a run is killed and lists only snapshots that exist. Entries of the same time
// with different `part` numbers (fluid 0, membrane 1) appear as blocks of one dataset.
#include <filesystem>
#include <string>
#include <vector>

namespace capsflow::io {

struct PvdEntry {
  double time = 0.0;
  int part = 0;
  std::string file;  // relative to the .pvd's directory
  bool operator==(const PvdEntry&) const = default;
};

class PvdSeries {
 public:
  // An empty series; nothing is written until the first add().
  explicit PvdSeries(std::filesystem::path path) : path_(std::move(path)) {}

  // A series written earlier by PvdSeries (for a restart). Throws std::runtime_error naming
  // the file if it cannot be read or is not in that format. Series written before issue 15 named
  // their files relative to the working directory of the run ("out/case/fluid_000000.vtu"):
  // an entry that does not resolve against the .pvd's directory but whose file name does
  // is normalised to that name, since snapshots always sit next to their .pvd.
  [[nodiscard]] static PvdSeries load(const std::filesystem::path& path);

  // Lists `file` at `time` and rewrites the .pvd. `file` is relative to the .pvd's
  // directory (ParaView resolves it there), or absolute (then stored relative to it).
  void add(double time, const std::filesystem::path& file, int part = 0);

  // Drops the entries later than `time` (a restart from a checkpoint at that time) and
  // rewrites the .pvd.
  void truncate_after(double time);

  [[nodiscard]] const std::vector<PvdEntry>& entries() const { return entries_; }
  [[nodiscard]] const std::filesystem::path& path() const { return path_; }

 private:
  void rewrite() const;

  std::filesystem::path path_;
  std::vector<PvdEntry> entries_;
};

}  // namespace capsflow::io
