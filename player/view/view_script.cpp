#include "player/view/view_script.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

#include "common/error.h"
#include "common/input_file.h"

namespace fissure::view {

const std::vector<std::string>& toggle_features() {
  static const std::vector<std::string> names{"walls", "normal-mapping", "tessellation", "cage",
                                              "spheres", "replication-colors", "fragment-colors"};
  return names;
}

const std::vector<std::string>& material_parameters() {
  static const std::vector<std::string> names{"youngs_modulus", "poisson_ratio", "density", "toughness", "damping"};
  return names;
}

namespace {

std::string join(const std::vector<std::string>& names) {
  std::string out;
  for (const std::string& n : names) out += (out.empty() ? "" : ", ") + n;
  return out;
}

class LineReader {
 public:
  LineReader(const std::string& line, std::string where) : m_in(line), m_where(std::move(where)) {}

  template <typename T>
  T number(const char* what) {
    T value{};
    if (!(m_in >> value) || !std::isfinite(static_cast<double>(value))) {
      throw Error(m_where + ": expected " + what, "see `fissure-player view --help` for the script's actions");
    }
    return value;
  }
  std::string word(const char* what) {
    std::string w;
    if (!(m_in >> w)) throw Error(m_where + ": expected " + what, "see `fissure-player view --help`");
    return w;
  }
  void end() {
    std::string extra;
    if (m_in >> extra) throw Error(m_where + ": unexpected '" + extra + "'", "one action per line");
  }
  [[nodiscard]] const std::string& where() const { return m_where; }

 private:
  std::istringstream m_in;
  std::string m_where;
};

ScriptAction parse_line(const std::string& command, LineReader& in) {
  using Kind = ScriptAction::Kind;
  ScriptAction a;
  if (command == "wait" || command == "step") {
    a.kind = command == "wait" ? Kind::Wait : Kind::Step;
    a.count = in.number<long>("a count of frames or steps");
    if (a.count < 1 || a.count > 1'000'000) throw Error(in.where() + ": count " + std::to_string(a.count) + " is out of range", "give 1 to 1000000");
  } else if (command == "seek") {
    a.kind = Kind::Seek;
    a.count = in.number<long>("a frame of the replay");
    if (a.count < 0) throw Error(in.where() + ": frame " + std::to_string(a.count) + " is negative", "frames count from 0");
  } else if (command == "pause" || command == "resume" || command == "quit") {
    a.kind = command == "pause" ? Kind::Pause : command == "resume" ? Kind::Resume : Kind::Quit;
  } else if (command == "fire") {
    a.kind = Kind::Fire;
    a.x = in.number<float>("a pixel's x");
    a.y = in.number<float>("a pixel's y");
  } else if (command == "shot") {
    a.kind = Kind::Shot;
    a.mass = in.number<float>("a mass [kg]");
    a.radius = in.number<float>("a radius [m]");
    a.speed = in.number<float>("a speed [m/s]");
    if (!(a.mass > 0 && a.radius > 0 && a.speed > 0)) throw Error(in.where() + ": a shot's mass, radius and speed must be > 0", "e.g. shot 2 0.05 15");
  } else if (command == "toggle") {
    a.kind = Kind::Toggle;
    a.name = in.word("a feature");
    const auto& names = toggle_features();
    if (std::find(names.begin(), names.end(), a.name) == names.end()) {
      throw Error(in.where() + ": no feature '" + a.name + "'", "toggle one of: " + join(names));
    }
  } else if (command == "set") {
    a.kind = Kind::Set;
    a.name = in.word("an object's name");
    a.parameter = in.word("a parameter");
    const auto& names = material_parameters();
    if (std::find(names.begin(), names.end(), a.parameter) == names.end()) {
      throw Error(in.where() + ": no parameter '" + a.parameter + "'", "set one of: " + join(names));
    }
    a.value = in.number<double>("a value");
  } else if (command == "screenshot") {
    a.kind = Kind::Screenshot;
    a.name = in.word("a PNG path");
  } else {
    throw Error(in.where() + ": unknown action '" + command + "'",
                "actions: wait, pause, resume, step, seek, fire, shot, toggle, set, screenshot, quit");
  }
  in.end();
  return a;
}

}  // namespace

std::vector<ScriptAction> parse_script(const std::string& text, const std::string& source) {
  std::vector<ScriptAction> actions;
  std::istringstream lines(text);
  std::string line;
  for (int number = 1; std::getline(lines, line); ++number) {
    line = line.substr(0, line.find('#'));
    LineReader in(line, source + ":" + std::to_string(number));
    std::string command;
    {
      std::istringstream first(line);
      if (!(first >> command)) continue;
    }
    in.word("an action");
    ScriptAction action = parse_line(command, in);
    action.line = number;
    actions.push_back(std::move(action));
  }
  return actions;
}

std::vector<ScriptAction> read_script(const std::filesystem::path& path) {
  return parse_script(read_input_file(path, std::uint64_t{64} << 20), path.string());
}

}  // namespace fissure::view
