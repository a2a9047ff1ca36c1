// Text files a study writes, checked (a full disk is an error, not a short file), and the
// committed CSVs embedded in the binary, read back as cells.
#pragma once

#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>
#include <vector>

namespace plumage::studies {

// Closes `out`, a file written to `path`, and throws IoError naming the path if opening it, a
// write or the close failed: an ofstream reports none of these itself, so a full disk would
// otherwise leave a short file and a run that says it succeeded.
void close_written(std::ofstream& out, const std::filesystem::path& path);

// Writes `text` to `path` (replacing it); IoError naming the path as close_written.
void write_text_file(const std::filesystem::path& path, std::string_view text);

// The rows of a CSV embedded in the binary (a committed reference, configured into a generated
// header) as cells, header first; blank lines skipped, no quoting (the references have none).
std::vector<std::vector<std::string>> embedded_csv_rows(std::string_view text);

}  // namespace plumage::studies
