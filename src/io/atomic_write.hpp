#pragma once
// Every file capsflow writes goes through atomic_write: the content is written to a
// temporary name in the target's directory and renamed over the target only once the
// writer has returned. rename(2) within one file system is atomic, so a run killed at any
// moment leaves either the previous complete file or the new complete file, never a
// truncated one. (No fsync: the failure we guard against is a killed process, not a power
// cut, and syncing every snapshot would cost more than it saves.) The temporary is removed
// when the writer throws; a process killed mid-write leaves it behind, which is why
// `capsflow run` defers SIGINT and SIGTERM to the end of a step (app/interrupt.hpp): only a
// second signal or SIGKILL can interrupt a write.
#include <filesystem>
#include <functional>
#include <string_view>

namespace capsflow::io {

// Calls write(temporary_path); on success renames the temporary file to `target`. If the
// writer throws, the temporary file is removed and the exception propagates; the target is
// left untouched. The target's directory must exist. Throws std::runtime_error naming the
// file when the rename fails or the writer returned without creating the file.
void atomic_write(const std::filesystem::path& target,
                  const std::function<void(const std::filesystem::path& temporary)>& write);

// The two halves of atomic_write, for writers that are several processes (a checkpoint on N
// ranks: every rank writes into the one temporary, rank 0 commits it): a hidden temporary
// name next to target, unique to this process and call; and the rename into place (throws
// std::runtime_error naming the file, and removes the temporary, if it fails or the
// temporary does not exist).
[[nodiscard]] std::filesystem::path temporary_path_for(const std::filesystem::path& target);
void commit_temporary(const std::filesystem::path& temporary, const std::filesystem::path& target);

// atomic_write of a text (or any byte string).
void atomic_write_text(const std::filesystem::path& target, std::string_view content);

}  // namespace capsflow::io
