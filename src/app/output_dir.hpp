#pragma once
// The output folder, checked before any work: a run must be able to write there, and must
// not write over another run by accident.
#include <filesystem>
#include <optional>
#include <stdexcept>

namespace capsflow::app {

// A command line this machine or this folder cannot serve (exit status 2, one line, before
// any work): an unusable --out, another run's folder, a run too big for the memory.
class RequestError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// True when `restart` is a checkpoint inside `out`: the run continues its own diagnostics and
// series there. Otherwise (a new folder, or another run's with --force) they start afresh.
[[nodiscard]] bool continues_in_place(const std::filesystem::path& out,
                                      const std::optional<std::filesystem::path>& restart);

// Creates `out` if needed and writes (then removes) a probe file in it. Throws RequestError
// naming the folder if it cannot, or if it holds another run (diagnostics.csv, case.toml,
// series.pvd or a checkpoint) and neither `force` is set nor `restart` is a checkpoint in
// that same folder (the way to continue a run in place). Returns true if it created `out`.
bool prepare_output_dir(const std::filesystem::path& out, bool force,
                        const std::optional<std::filesystem::path>& restart);

// Removes `out` if prepare_output_dir created it and it is still empty: input refused after
// the check (a corrupt checkpoint) leaves no trace.
void remove_if_created_and_empty(const std::filesystem::path& out, bool created);

}  // namespace capsflow::app
