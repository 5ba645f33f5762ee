#pragma once
// The study's plots: tools/plot_study.py (numpy, matplotlib) on the study folder.
#include <filesystem>

namespace capsflow::app::study {

// Runs the plot script on `dir` (study.csv, orders.csv, equal_error.csv and the members'
// diagnostics). Without python3, numpy, matplotlib or the script: one warning line on
// stderr (the CSV files are written anyway); returns false then or when the script fails.
bool make_plots(const std::filesystem::path& dir, const std::filesystem::path& executable);

}  // namespace capsflow::app::study
