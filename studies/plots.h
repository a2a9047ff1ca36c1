// Plots drawn by matplotlib under Python (python3-matplotlib, python3-numpy, python3-h5py;
// scripts/install-deps.sh installs them). The script is embedded in the binary.
//
// A figure is never worth the data: a plot that cannot be drawn (no interpreter, a missing
// module, the script failing) is a warning on stderr naming what is missing, and the study
// goes on to commit its records and report without that PNG.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace plumage::studies {

// The interpreter: $PLUMAGE_PYTHON if set, else /usr/bin/python3 (Debian's, where the
// packages above install).
std::string python_interpreter();

// Process-wide switch for `--no-plots` (default: on).
void set_plots_enabled(bool enabled);
bool plots_enabled();

// kind: "spectra" (CSV → PNG) or "chart" (HDF5 → PNG); see studies/plots.py. Returns whether
// the PNG was drawn (false: disabled, or a warning was printed).
bool run_plot(const std::string& kind, const std::filesystem::path& input,
              const std::filesystem::path& png);

// Several plots with one interpreter start (importing matplotlib takes most of a small
// plot's time). The job list is written to `job_list` (a CSV: kind, input, png).
struct PlotJob {
    std::string kind;
    std::filesystem::path input, png;
};
bool run_plots(const std::vector<PlotJob>& jobs, const std::filesystem::path& job_list);

}  // namespace plumage::studies
