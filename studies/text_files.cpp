#include "studies/text_files.h"

#include <fmt/format.h>

#include "common/error.h"

namespace plumage::studies {

void close_written(std::ofstream& out, const std::filesystem::path& path) {
    out.close();
    if (!out) throw IoError(fmt::format("cannot write {}", path.string()));
}

void write_text_file(const std::filesystem::path& path, std::string_view text) {
    std::ofstream out(path);
    out << text;
    close_written(out, path);
}

std::vector<std::vector<std::string>> embedded_csv_rows(std::string_view text) {
    std::vector<std::vector<std::string>> rows;
    std::size_t at = 0;
    while (at < text.size()) {
        std::size_t end = text.find('\n', at);
        if (end == std::string_view::npos) end = text.size();
        std::string_view line = text.substr(at, end - at);
        at = end + 1;
        if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
        if (line.empty()) continue;
        std::vector<std::string> cells;
        std::size_t from = 0;
        while (true) {
            const std::size_t comma = line.find(',', from);
            cells.emplace_back(
                line.substr(from, comma == std::string_view::npos ? comma : comma - from));
            if (comma == std::string_view::npos) break;
            from = comma + 1;
        }
        rows.push_back(std::move(cells));
    }
    return rows;
}

}  // namespace plumage::studies
