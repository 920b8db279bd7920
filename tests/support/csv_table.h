#pragma once
/// A CSV file a benchmark writes next to its Markdown tables, so that
/// pipelines/tradeoffs can plot the figures without parsing text meant for people.
/// Numbers are written with 9 significant digits, unitless and unformatted; the column
/// names carry the units.

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <string>
#include <type_traits>
#include <vector>

#include "common/error.h"

namespace fissure::testing {

/// One cell: a number or a word (a model or solver name). Words must not hold commas,
/// quotes or line breaks; the benchmarks only write fixed names.
class CsvCell {
 public:
  template <typename Number, typename = std::enable_if_t<std::is_arithmetic_v<Number>>>
  CsvCell(Number value) {  // NOLINT(google-explicit-constructor): rows read as lists of values
    char buffer[32];
    std::snprintf(buffer, sizeof buffer, "%.9g", static_cast<double>(value));
    text_ = buffer;
  }
  CsvCell(const char* word) : text_(word) {}          // NOLINT(google-explicit-constructor)
  CsvCell(std::string word) : text_(std::move(word)) {}  // NOLINT(google-explicit-constructor)
  [[nodiscard]] const std::string& text() const { return text_; }

 private:
  std::string text_;
};

/// `DIR/NAME.csv` with a header row, or nothing at all when `dir` is empty (the
/// benchmark was run without --csv). Each row is flushed, so a run stopped halfway
/// leaves the rows it measured.
class CsvTable {
 public:
  CsvTable(const std::filesystem::path& dir, const std::string& name, std::initializer_list<const char*> columns)
      : columns_(columns.size()) {
    if (dir.empty()) return;
    const std::filesystem::path path = dir / (name + ".csv");
    out_.open(path);
    if (!out_) throw Error("cannot write " + path.string(), "check that the --csv folder exists and is writable");
    write({columns.begin(), columns.end()});
  }

  void row(std::initializer_list<CsvCell> cells) {
    if (cells.size() != columns_) throw Error("a CSV row has " + std::to_string(cells.size()) + " cells for " +
                                              std::to_string(columns_) + " columns");
    std::vector<std::string> texts;
    for (const CsvCell& c : cells) texts.push_back(c.text());
    write(texts);
  }

 private:
  void write(const std::vector<std::string>& cells) {
    if (!out_.is_open()) return;
    for (std::size_t i = 0; i < cells.size(); ++i) out_ << (i ? "," : "") << cells[i];
    out_ << '\n' << std::flush;
  }

  std::size_t columns_;
  std::ofstream out_;
};

}  // namespace fissure::testing
