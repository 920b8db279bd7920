#pragma once
/// `view --script FILE`: actions the viewer takes as if a user did, one per frame, so
/// interactive behaviour can be tested and demonstrated without a person at the window.
///
///   # a comment; blank lines are skipped
///   wait N                    draw N frames doing nothing else
///   pause | resume
///   step N                    take N physics steps now (paused or not); in a replay,
///                             move N recorded frames on
///   seek FRAME                in a replay: go to recorded frame FRAME (from 0)
///   fire X Y                  shoot a projectile through pixel (X, Y), from the top left
///                             (not in a replay, which shows only what was recorded)
///   shot MASS RADIUS SPEED    what the next shots are [kg, m, m/s] (the panel's Shot)
///   toggle FEATURE            walls, normal-mapping, tessellation, cage, spheres,
///                             replication-colors, fragment-colors
///   set BODY PARAM VALUE      youngs_modulus, poisson_ratio, density, toughness or
///                             damping (Rayleigh mass α) of the object named BODY
///                             (not in a replay)
///   screenshot PATH           write the scene as drawn (without the panel) as PNG
///   quit

#include <filesystem>
#include <string>
#include <vector>

namespace fissure::view {

struct ScriptAction {
  enum class Kind { Wait, Pause, Resume, Step, Seek, Fire, Shot, Toggle, Set, Screenshot, Quit };
  Kind kind = Kind::Wait;
  long count = 1;               ///< wait, step; seek: the frame
  float x = 0, y = 0;           ///< fire [pixels]
  float mass = 0, radius = 0, speed = 0;  ///< shot
  std::string name;             ///< toggle: the feature; set: the body; screenshot: the path
  std::string parameter;        ///< set
  double value = 0;             ///< set
  int line = 0;                 ///< in the script, for messages
};

/// The features `toggle` knows, as the panel names them.
const std::vector<std::string>& toggle_features();
const std::vector<std::string>& material_parameters();

/// Reads a script; throws fissure::Error naming the file, line and what is wrong.
std::vector<ScriptAction> read_script(const std::filesystem::path& path);
/// The same from text (`source` names it in messages).
std::vector<ScriptAction> parse_script(const std::string& text, const std::string& source);

}  // namespace fissure::view
