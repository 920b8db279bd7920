#include "player/view/panel.h"

#include <imgui.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace fissure::view {

namespace {

/// A logarithmic slider over a double (moduli, densities, tolerances span decades).
bool log_slider(const char* label, double& value, double low, double high, const char* format) {
  auto v = static_cast<float>(value);
  if (!ImGui::SliderFloat(label, &v, static_cast<float>(low), static_cast<float>(high), format,
                          ImGuiSliderFlags_Logarithmic)) {
    return false;
  }
  value = v;
  return true;
}

void plot(const char* label, const std::deque<float>& values) {
  if (values.empty()) return;
  const std::vector<float> data(values.begin(), values.end());
  const float peak = *std::max_element(data.begin(), data.end());
  char overlay[64];
  std::snprintf(overlay, sizeof overlay, "%.2f ms (max %.2f)", data.back(), peak);
  ImGui::PlotLines(label, data.data(), static_cast<int>(data.size()), 0, overlay, 0.0f, std::max(peak, 1e-3f),
                   ImVec2(0, 36));
}

void clock_section(PanelState& s, const sim::World& world) {
  ImGui::Text("t = %.4f s   dt = %.5f s", world.time(), world.settings().step.dt);
  if (ImGui::Button(s.paused ? "Resume (space)" : "Pause (space)")) s.paused = !s.paused;
  ImGui::SameLine();
  if (ImGui::Button("Step (N)")) ++s.pending_steps;
  ImGui::SameLine();
  if (ImGui::Button("Reset (R)")) s.reset_requested = true;
  ImGui::SameLine();
  if (ImGui::Button("Screenshot (P)")) s.screenshot_requested = true;
  ImGui::SliderFloat("time scale", &s.time_scale, 0.01f, 1.0f, "%.2fx", ImGuiSliderFlags_Logarithmic);
  ImGui::SliderInt("steps/frame", &s.steps_per_frame, 0, 16, s.steps_per_frame == 0 ? "real time" : "%d");
}

/// A replay's clock: the recording's timeline instead of the solver's.
bool replay_section(PanelState& s, const sim::World& world) {
  ImGui::Text("replay: t = %.4f s, step %ld, frame %d of %zu", world.time(), s.replay.step, s.replay.frame,
              s.replay.frames);
  if (ImGui::Button(s.paused ? "Play (space)" : "Pause (space)")) s.paused = !s.paused;
  ImGui::SameLine();
  if (ImGui::Button("<")) --s.pending_steps;
  ImGui::SameLine();
  if (ImGui::Button("> (N)")) ++s.pending_steps;
  ImGui::SameLine();
  if (ImGui::Button("Start (R)")) s.reset_requested = true;
  ImGui::SameLine();
  if (ImGui::Button("Screenshot (P)")) s.screenshot_requested = true;
  const bool moved = ImGui::SliderInt("frame", &s.replay.frame, 0, static_cast<int>(s.replay.frames) - 1);
  ImGui::SliderFloat("time scale", &s.time_scale, 0.01f, 1.0f, "%.2fx", ImGuiSliderFlags_Logarithmic);
  ImGui::SliderInt("frames/frame", &s.steps_per_frame, 0, 16, s.steps_per_frame == 0 ? "real time" : "%d");
  return moved;
}

void shot_section(PanelState& s) {
  if (!ImGui::CollapsingHeader("Shot (click the scene)")) return;
  ImGui::SliderFloat("mass [kg]", &s.shot.mass, 0.01f, 100.0f, "%.2f", ImGuiSliderFlags_Logarithmic);
  ImGui::SliderFloat("radius [m]", &s.shot.radius, 0.005f, 1.0f, "%.3f", ImGuiSliderFlags_Logarithmic);
  ImGui::SliderFloat("speed [m/s]", &s.shot.speed, 0.1f, 200.0f, "%.1f", ImGuiSliderFlags_Logarithmic);
}

std::optional<std::size_t> object_section(PanelState& s) {
  std::optional<std::size_t> edited;
  if (!ImGui::CollapsingHeader("Objects", ImGuiTreeNodeFlags_DefaultOpen)) return edited;
  for (std::size_t b = 0; b < s.bodies.size(); ++b) {
    BodyControls& c = s.bodies[b];
    ImGui::PushID(static_cast<int>(b));
    if (ImGui::TreeNodeEx(c.name.c_str(), ImGuiTreeNodeFlags_DefaultOpen)) {
      bool changed = log_slider("Young's modulus [Pa]", c.material.youngs_modulus, 1e3, 1e12, "%.3g");
      auto nu = static_cast<float>(c.material.poisson_ratio);
      if (ImGui::SliderFloat("Poisson ratio", &nu, 0.0f, 0.49f, "%.3f")) {
        c.material.poisson_ratio = nu;
        changed = true;
      }
      changed |= log_slider("density [kg/m^3]", c.material.density, 1.0, 1e5, "%.4g");
      bool breakable = std::isfinite(c.toughness);
      if (ImGui::Checkbox("breakable", &breakable)) {
        c.toughness = breakable ? 100.0 : std::numeric_limits<double>::infinity();
        changed = true;
      }
      if (breakable) changed |= log_slider("toughness [N]", c.toughness, 0.01, 1e6, "%.4g");
      auto damping = static_cast<float>(c.material.rayleigh_mass);
      if (ImGui::SliderFloat("damping alpha [1/s]", &damping, 0.0f, 20.0f, "%.2f")) {
        c.material.rayleigh_mass = damping;
        changed = true;
      }
      if (changed) edited = b;
      ImGui::TreePop();
    }
    ImGui::PopID();
  }
  return edited;
}

bool solver_section(PanelState& s) {
  if (!ImGui::CollapsingHeader("Solver")) return false;
  sim::StepSettings& step = s.settings.step;
  bool changed = log_slider("dt [s]", step.dt, 1e-4, 0.05, "%.5f");
  int solver = step.solver == sim::LinearSolver::Direct ? 0 : 1;
  if (ImGui::Combo("linear solver", &solver, "direct (Cholesky)\0conjugate gradients\0")) {
    step.solver = solver == 0 ? sim::LinearSolver::Direct : sim::LinearSolver::ConjugateGradient;
    changed = true;
  }
  if (step.solver == sim::LinearSolver::ConjugateGradient) changed |= log_slider("CG tolerance", step.tolerance, 1e-10, 1e-2, "%.1e");
  changed |= ImGui::Checkbox("fracture", &s.settings.fracture);
  changed |= ImGui::Checkbox("self-collision", &s.settings.self_collision);
  return changed;
}

bool features_section(PanelState& s) {
  if (!ImGui::CollapsingHeader("Drawing", ImGuiTreeNodeFlags_DefaultOpen)) return false;
  Features& f = s.features;
  bool changed = ImGui::Checkbox("walls", &f.walls);
  changed |= ImGui::Checkbox("normal mapping", &f.normal_mapping);
  changed |= ImGui::Checkbox("tessellated relief", &f.tessellation);
  changed |= ImGui::Checkbox("cage", &f.cage);
  changed |= ImGui::Checkbox("collision spheres", &f.spheres);
  changed |= ImGui::Checkbox("replication colours", &f.replication_colors);
  changed |= ImGui::Checkbox("fragment colours", &f.fragment_colors);
  return changed;
}

void statistics_section(const PanelState& s, const sim::World& world, const StepHistory& history) {
  if (!ImGui::CollapsingHeader("Timings and counters", ImGuiTreeNodeFlags_DefaultOpen)) return;
  ImGui::Text("fragments %ld   splits %ld   contacts %ld", static_cast<long>(world.fragment_count()), history.splits,
              history.contacts);
  if (s.replay.frames == 0) {  // a replay poses nodes without velocities: its energy would mislead
    ImGui::Text("energy %.4g J (kinetic + elastic + gravity)",
                world.kinetic_energy() + world.elastic_energy() + world.potential_energy());
  }
  for (int p = 0; p < StepHistory::PhaseCount; ++p) plot(StepHistory::kPhaseNames[static_cast<std::size_t>(p)], history.ms[static_cast<std::size_t>(p)]);
  plot("render", s.render_ms);
}

}  // namespace

PanelEdits draw_panel(PanelState& state, const sim::World& world, const StepHistory& history) {
  PanelEdits edits;
  ImGui::SetNextWindowPos(ImVec2(8, 8), ImGuiCond_FirstUseEver);
  ImGui::SetNextWindowSize(ImVec2(430, 0), ImGuiCond_FirstUseEver);
  ImGui::SetNextWindowCollapsed(false, ImGuiCond_FirstUseEver);
  // ImGui's default font is ASCII only: labels say "alpha", "m^3".
  ImGui::Begin("fissure (H hides)");
  ImGui::PushItemWidth(-170.0f);
  if (!state.status.empty()) ImGui::TextColored(ImVec4(1.0f, 0.45f, 0.35f, 1.0f), "%s", state.status.c_str());
  if (state.replay.frames > 0) {
    edits.seek = replay_section(state, world);
  } else {
    clock_section(state, world);
    shot_section(state);
    edits.body = object_section(state);
    edits.settings = solver_section(state);
  }
  edits.features = features_section(state);
  statistics_section(state, world, history);
  ImGui::PopItemWidth();
  ImGui::End();
  return edits;
}

}  // namespace fissure::view
