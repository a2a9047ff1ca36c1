// Plots drawn by matplotlib under Debian's /usr/bin/python3 (python3-matplotlib,
// python3-h5py; scripts/install-deps.sh installs them). The script is embedded in the
// binary. A missing interpreter or module is an IoError that says what to install.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace plumage::studies {

// kind: "spectra" (CSV → PNG) or "chart" (HDF5 → PNG); see studies/plots.py.
void run_plot(const std::string& kind, const std::filesystem::path& input,
              const std::filesystem::path& png);

// Several plots with one interpreter start (importing matplotlib takes most of a small
// plot's time). The job list is written to `job_list` (a CSV: kind, input, png).
struct PlotJob {
    std::string kind;
    std::filesystem::path input, png;
};
void run_plots(const std::vector<PlotJob>& jobs, const std::filesystem::path& job_list);

}  // namespace plumage::studies
