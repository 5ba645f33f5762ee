// The capsflow command (DESIGN.md, "What the user sees"). Exit status: 0 done, 2 bad
// input (one line on stderr naming the file or key), 3 a run that failed on the way, 130 or
// 143 a run stopped by SIGINT or SIGTERM after writing a checkpoint (interrupt.hpp).
#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include <cstdio>
#include <exception>
#include <new>
#include <string>

#include "app/exit_status.hpp"
#include "app/interrupt.hpp"
#include "app/memory_estimate.hpp"
#include "app/output_dir.hpp"
#include "app/progress.hpp"
#include "app/run_case.hpp"
#include "app/study/study_command.hpp"
#include "io/errors.hpp"
#include "parallel/comm.hpp"

namespace {

// One line on stderr; after the end of a progress line that is still open on the terminal.
void report(const std::string& message) {
  if (capsflow::app::progress_line_open()) std::fputc('\n', stderr);
  std::fprintf(stderr, "capsflow: %s\n", message.c_str());
}

}  // namespace

int main(int argc, char** argv) {
  using capsflow::app::RunRequest;
  // MPI only when a launcher started us (parallel/comm.hpp); a plain run makes no MPI call.
  capsflow::parallel::MpiSession mpi(argc, argv);
  const auto world = capsflow::parallel::Comm::world();
  CLI::App cli{"capsflow: elastic capsules in confined flows (finite volumes on an adaptive octree, "
               "finite-element membranes, immersed boundaries)"};
  cli.set_version_flag("--version", CAPSFLOW_VERSION);
  cli.require_subcommand(1);

  RunRequest request;
  std::string adapt;
  std::string out, restart, max_memory;
  auto* run = cli.add_subcommand("run", "Run a case file; outputs go to --out (default out/<case name>)");
  run->add_option("case", request.case_file, "Case file (TOML; docs/case-file.md)")->required();
  run->add_option("--adapt", adapt, "Adaptive refinement on or off (overrides adapt.enabled)")
      ->check(CLI::IsMember({"on", "off"}));
  run->add_option("--set", request.overrides, "Override a key of the case file: --set fluid.Re=10 (repeatable)")
      ->type_name("KEY=VALUE");
  // An empty path (a shell variable that expanded to nothing) must not fall back to the
  // default folder or to a fresh start: refused like any other bad argument.
  const auto not_empty = [](const std::string& v) { return v.empty() ? std::string("the path is empty") : std::string(); };
  run->add_option("--out", out, "Output directory")->check(not_empty);
  run->add_option("--restart", restart, "Continue from a checkpoint_NNNNNN.h5 of this case")->check(not_empty);
  run->add_flag("--quiet", request.quiet, "No progress line");
  run->add_option("--max-memory", max_memory,
                  "Refuse a run whose memory estimate (all MPI ranks together) exceeds this (e.g. 4G, 512M); runs "
                  "are always refused when a node cannot hold its ranks' share of the estimate")
      ->type_name("SIZE");
  run->add_flag("--force", request.force,
                "Write into --out even if it holds another run (diagnostics.csv, case.toml, series.pvd or "
                "checkpoints); without it such a folder is refused, unless --restart continues from a "
                "checkpoint in it");

  capsflow::app::study::StudyRequest study_request;
  auto* study = capsflow::app::study::add_study_subcommand(cli, study_request);

  try {
    cli.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // Every rank parses the same arguments; rank 0 speaks.
    if (!world.is_root()) return e.get_exit_code() == 0 ? 0 : 2;
    if (e.get_exit_code() == 0) return cli.exit(e);  // --help, --version
    std::fprintf(stderr, "capsflow: %s (see capsflow --help)\n", e.what());
    return 2;
  }
  if (study->parsed()) {
    // A study launches its members as processes of its own; N copies of it would run every
    // member N times over the same folders.
    if (world.size() > 1) {
      if (world.is_root())
        std::fprintf(stderr, "capsflow: study on %d MPI ranks: run the study without mpirun (its members are "
                             "separate runs)\n", world.size());
      return 2;
    }
    return capsflow::app::study::run_study(study_request);
  }
  if (!adapt.empty()) request.adapt = adapt == "on";
  if (!out.empty()) request.out = out;
  if (!restart.empty()) request.restart = restart;
  if (!max_memory.empty()) {
    try {
      request.max_memory = capsflow::app::parse_memory_size(max_memory);
    } catch (const std::invalid_argument& e) {
      if (world.is_root()) std::fprintf(stderr, "capsflow: --max-memory %s: %s\n", max_memory.c_str(), e.what());
      return 2;
    }
  }
  if (!world.is_root()) request.quiet = true;  // one progress line, rank 0's

  try {
    capsflow::app::run_case(request);
  } catch (...) {
    const auto failure = capsflow::app::exit_status_of(std::current_exception(), request.case_file.string());
    if (world.is_root()) {
      if (!failure.message.empty()) report(failure.message);
    } else if (!failure.collective) {
      // Only this rank failed (out of memory, a lost file): the others would wait for it
      // forever. Say it, then stop the whole run with the status.
      report(fmt::format("rank {}: {}", world.rank(), failure.message));
      MPI_Abort(world.handle(), failure.status);
    }
    return failure.status;
  }
  return 0;
}
