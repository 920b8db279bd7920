#pragma once
/// Command-line numbers for both CLIs (header-only: only the executables link CLI11).
/// CLI11 parses "nan", "inf" and "1e999" into floating-point options, and its range
/// validators compare with < and >, which NaN passes (issue 46: `--winding-accuracy nan`
/// and `--tessellation nan` were accepted). Every floating-point option of an app gets
/// a check that refuses them, so a flag added later cannot forget it.

#include <CLI/CLI.hpp>

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <string>

namespace fissure {

/// Refuses a value that reads as NaN or infinity (or overflows to it).
inline CLI::Validator finite_number() {
  return CLI::Validator(
      [](std::string& text) -> std::string {
        const char* begin = text.c_str();
        char* end = nullptr;
        errno = 0;
        const double value = std::strtod(begin, &end);
        if (end == begin) return {};  // not a number at all: CLI11's own conversion reports it
        if (!std::isfinite(value) || (errno == ERANGE && std::abs(value) > 1.0)) {
          return "'" + text + "' is not a finite number";
        }
        return {};
      },
      "", "FINITE");
}

/// Adds finite_number() to every floating-point option of `app` and its subcommands.
inline void refuse_non_finite_numbers(CLI::App& app) {
  for (CLI::Option* option : app.get_options()) {
    if (option->get_type_name().find("FLOAT") != std::string::npos) option->check(finite_number());
  }
  for (CLI::App* command : app.get_subcommands({})) refuse_non_finite_numbers(*command);
}

/// What a CLI returns for a command-line error: CLI11 prints the message (or the help,
/// or the version, which are exit 0); every usage error is exit 1, like any bad input.
inline int usage_exit_code(CLI::App& app, const CLI::ParseError& error) { return app.exit(error) == 0 ? 0 : 1; }

}  // namespace fissure
