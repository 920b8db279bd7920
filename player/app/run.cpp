#include "player/app/run.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>

#include "common/error.h"
#include "common/json_writer.h"
#include "common/log.h"
#include "formats/trajectory.h"
#include "player/app/scene_loader.h"

namespace fissure::player {

namespace {

using Clock = std::chrono::steady_clock;

struct PhaseStats {
  double total = 0, max = 0;
  void add(double seconds) {
    total += seconds;
    max = std::max(max, seconds);
  }
};

struct Phases {
  PhaseStats forces, assembly, solve, fracture, collisions, step;
};

struct Summary {
  double energy_initial = 0, energy_final = 0, energy_max = 0;
  Vec3 momentum_initial, momentum_final, angular_initial, angular_final;
  std::size_t splits = 0, exposed = 0, contacts = 0, swept = 0, unconverged = 0, response_iterations = 0;
  long iterations = 0;
  long factorizations = 0;
  int substeps_max = 1;
  double sphere_penetration_max = 0, vertex_penetration_max = 0;
  double sphere_penetration_final = 0, vertex_penetration_final = 0;
};

double total_energy(const sim::World& w) { return w.kinetic_energy() + w.elastic_energy() + w.potential_energy(); }

void write_vec(JsonWriter& json, const char* name, const Vec3& v) {
  json.key(name).begin_array().value(v.x()).value(v.y()).value(v.z()).end_array();
}

void write_phase(JsonWriter& json, const char* name, const PhaseStats& p, long steps) {
  json.key(name).begin_object();
  json.key("mean_ms").value(1e3 * p.total / static_cast<double>(std::max(steps, 1L)));
  json.key("max_ms").value(1e3 * p.max);
  json.key("total_s").value(p.total);
  json.end_object();
}

const char* solver_name(const sim::WorldSettings& s) {
  if (s.step.solver == sim::LinearSolver::Direct) return "direct (CHOLMOD supernodal Cholesky)";
  return s.step.preconditioner == sim::Preconditioner::Jacobi ? "conjugate gradients (Jacobi)"
                                                              : "conjugate gradients (lagged Cholesky)";
}

}  // namespace

int run_scene(const formats::Scene& scene, const RunOptions& options) {
  if (options.steps < 0) throw Error("--steps " + std::to_string(options.steps) + " is negative", "give 0 or more steps");
  if (options.trajectory_every < 1) {
    throw Error("--trajectory-every " + std::to_string(options.trajectory_every) + " is below 1",
                "record every k-th step with k ≥ 1");
  }
  const auto load_start = Clock::now();
  LoadedScene loaded = load_scene(scene);
  sim::World& world = loaded.world;
  const double load_seconds = std::chrono::duration<double>(Clock::now() - load_start).count();
  std::size_t tets = 0, nodes = 0, spheres = 0, vertices = 0;
  for (const sim::Body& b : world.bodies()) {
    tets += b.integrator().elasticity().tet_count();
    nodes += b.integrator().node_count();
    spheres += b.spheres.size();
    vertices += b.vertices.size();
  }
  log_info(scene.file.filename().string() + ": " + std::to_string(world.bodies().size()) + " bodies, " +
           std::to_string(tets) + " tets, " + std::to_string(nodes) + " nodes, " + std::to_string(spheres) +
           " spheres, " + std::to_string(vertices) + " render vertices; loaded in " +
           std::to_string(load_seconds).substr(0, 5) + " s");

  formats::Trajectory trajectory;
  trajectory.scene = scene.file.filename().string();
  trajectory.bodies.resize(world.bodies().size());
  auto record = [&](long step) {
    trajectory.time.push_back(world.time());
    trajectory.step.push_back(static_cast<std::uint64_t>(step));
    for (std::size_t b = 0; b < world.bodies().size(); ++b) {
      trajectory.bodies[b].name = world.bodies()[b].name;
      trajectory.bodies[b].frames.push_back(world.bodies()[b].integrator().positions());
    }
  };
  std::vector<std::vector<NodeIndex>> split_from(world.bodies().size());
  std::vector<Index> initial_nodes;
  for (std::size_t b = 0; b < world.bodies().size(); ++b) {
    initial_nodes.push_back(world.bodies()[b].integrator().node_count());
    split_from[b].assign(initial_nodes.back(), kInvalidIndex);
  }
  const bool recording = !options.trajectory.empty();
  if (recording) record(0);

  Summary summary;
  summary.energy_initial = summary.energy_max = total_energy(world);
  summary.momentum_initial = world.linear_momentum();
  summary.angular_initial = world.angular_momentum();
  Phases phases;
  auto last_progress = Clock::now();
  const auto run_start = Clock::now();
  for (long step = 1; step <= options.steps; ++step) {
    const auto step_start = Clock::now();
    const sim::StepReport r = world.step();
    if (!r.status.ok()) {
      const sim::StepFailure failure = world.explain(r.status);
      throw Error(failure.message, failure.hint);
    }
    phases.step.add(std::chrono::duration<double>(Clock::now() - step_start).count());
    phases.forces.add(r.forces);
    phases.assembly.add(r.assembly);
    phases.solve.add(r.solve);
    phases.fracture.add(r.fracture);
    phases.collisions.add(r.collisions);
    summary.splits += r.splits.size();
    summary.exposed += r.exposed.size();
    summary.contacts += r.contacts.contacts;
    summary.swept += r.contacts.swept;
    summary.response_iterations += r.contacts.response_iterations;
    summary.unconverged += r.unconverged ? 1 : 0;
    summary.iterations += r.solver_iterations;
    summary.factorizations += r.factorizations;
    summary.substeps_max = std::max(summary.substeps_max, r.substeps);
    for (const auto& [body, split] : r.splits) {
      split_from[body].resize(std::max<std::size_t>(split_from[body].size(), split.added + 1), kInvalidIndex);
      split_from[body][split.added] = split.node;
      if (recording) {
        trajectory.splits.push_back({static_cast<std::uint64_t>(step), world.time(), body, split.node, split.added,
                                     split.normal, split.eigenvalue});
      }
    }
    if (recording) {
      for (const auto& [body, face] : r.exposed) {
        trajectory.exposed_faces.push_back(
            {static_cast<std::uint64_t>(step), body, face.tet, static_cast<std::uint8_t>(face.face)});
      }
      if (step % options.trajectory_every == 0 || step == options.steps) record(step);
    }
    // Measured outside the timed phases: what a viewer would see penetrate.
    if (scene.features.collisions) {
      summary.sphere_penetration_final = world.sphere_penetration();
      summary.vertex_penetration_final = world.vertex_penetration();
      summary.sphere_penetration_max = std::max(summary.sphere_penetration_max, summary.sphere_penetration_final);
      summary.vertex_penetration_max = std::max(summary.vertex_penetration_max, summary.vertex_penetration_final);
    }
    const double energy = total_energy(world);
    if (log_level() >= LogLevel::Debug) {
      log_debug("step " + std::to_string(step) + " kinetic " + std::to_string(world.kinetic_energy()) + " elastic " +
                std::to_string(world.elastic_energy()) + " gravity " + std::to_string(world.potential_energy()) +
                " contacts " + std::to_string(r.contacts.contacts) + " iterations " + std::to_string(r.solver_iterations));
    }
    summary.energy_max = std::max(summary.energy_max, energy);
    if (!std::isfinite(energy)) {
      throw Error("at step " + std::to_string(step) + " (t = " + std::to_string(world.time()) +
                      " s) the state became non-finite",
                  "use a smaller solver.dt or set solver.min_dt; please report the scene");
    }
    if (std::chrono::duration<double>(Clock::now() - last_progress).count() > 2.0) {
      last_progress = Clock::now();
      log_info("step " + std::to_string(step) + "/" + std::to_string(options.steps) + "  t = " +
               std::to_string(world.time()).substr(0, 6) + " s  fragments " + std::to_string(world.fragment_count()) +
               "  " + std::to_string(1e3 * phases.step.total / static_cast<double>(step)).substr(0, 6) + " ms/step");
    }
  }
  const double run_seconds = std::chrono::duration<double>(Clock::now() - run_start).count();
  summary.energy_final = total_energy(world);
  summary.momentum_final = world.linear_momentum();
  summary.angular_final = world.angular_momentum();
  const long steps = options.steps;
  const double per_step = 1e3 / static_cast<double>(std::max(steps, 1L));

  std::printf("%ld steps of %.6g s (%.4g s simulated) in %.3f s wall\n", steps, scene.solver.dt, world.time(),
              run_seconds);
  std::printf("phase        mean ms    max ms\n");
  const std::pair<const char*, const PhaseStats*> rows[] = {
      {"forces", &phases.forces}, {"assembly", &phases.assembly}, {"solve", &phases.solve},
      {"fracture", &phases.fracture}, {"collisions", &phases.collisions}, {"step", &phases.step}};
  for (const auto& [name, p] : rows) std::printf("%-10s %9.3f %9.3f\n", name, p->total * per_step, 1e3 * p->max);
  std::printf("energy     %.6g J -> %.6g J (max %.6g J; kinetic + elastic + gravity)\n", summary.energy_initial,
              summary.energy_final, summary.energy_max);
  std::printf("momentum   |p| %.6g -> %.6g kg m/s, |L| %.6g -> %.6g kg m²/s\n", summary.momentum_initial.norm(),
              summary.momentum_final.norm(), summary.angular_initial.norm(), summary.angular_final.norm());
  std::printf("fracture   %zu splits, %zu faces exposed, %u fragments\n", summary.splits, summary.exposed,
              world.fragment_count());
  std::printf("contacts   %zu (%zu caught only by swept tests), penetration max: spheres %.3g m, render vertices %.3g m\n",
              summary.contacts, summary.swept, summary.sphere_penetration_max, summary.vertex_penetration_max);
  std::printf("response  %.1f conjugate-gradient iterations/step inside the implicit step\n",
              static_cast<double>(summary.response_iterations) * per_step / 1e3);
  std::printf("solver     %s, %.1f iterations/step, %ld factorizations, %zu steps hit the iteration cap, at most %d substeps\n",
              solver_name(world.settings()), static_cast<double>(summary.iterations) * per_step / 1e3,
              summary.factorizations, summary.unconverged, summary.substeps_max);

  if (!options.report.empty()) {
    JsonWriter json;
    json.begin_object();
    json.key("scene").value(scene.file.filename().string());
    json.key("steps").value(static_cast<std::int64_t>(steps));
    json.key("dt").value(scene.solver.dt);
    json.key("simulated_seconds").value(world.time());
    json.key("wall_seconds").value(run_seconds);
    json.key("load_seconds").value(load_seconds);
    json.key("solver").value(solver_name(world.settings()));
    json.key("stiffness").value(world.settings().step.stiffness == sim::StiffnessModel::Exact ? "exact" : "warped");
    json.key("collision_points")
        .value(world.settings().collision_points == sim::CollisionPoints::Spheres ? "spheres" : "render vertices");
    json.key("no_tunnelling")
        .value("swept tests: sphere-sphere time of impact, segment against the radius-grown box, half-space ground");
    json.key("bodies").begin_array();
    for (std::size_t b = 0; b < world.bodies().size(); ++b) {
      const sim::Body& body = world.bodies()[b];
      json.begin_object();
      json.key("name").value(body.name);
      json.key("bundle").value(loaded.assets[b].bundle_name);
      json.key("tets").value(static_cast<std::uint64_t>(body.integrator().elasticity().tet_count()));
      json.key("nodes_initial").value(static_cast<std::uint64_t>(initial_nodes[b]));
      json.key("nodes_final").value(static_cast<std::uint64_t>(body.integrator().node_count()));
      json.key("spheres").value(static_cast<std::uint64_t>(body.spheres.size()));
      json.key("render_vertices").value(static_cast<std::uint64_t>(body.vertices.size()));
      json.key("fragments").value(static_cast<std::uint64_t>(body.topology.fragment_count()));
      json.key("exposed_faces").value(static_cast<std::uint64_t>(body.topology.exposed_face_count()));
      json.end_object();
    }
    json.end_array();
    json.key("timings").begin_object();
    write_phase(json, "forces", phases.forces, steps);
    write_phase(json, "assembly", phases.assembly, steps);
    write_phase(json, "solve", phases.solve, steps);
    write_phase(json, "fracture", phases.fracture, steps);
    write_phase(json, "collisions", phases.collisions, steps);
    write_phase(json, "step", phases.step, steps);
    json.end_object();
    json.key("summary").begin_object();
    json.key("energy_initial_J").value(summary.energy_initial);
    json.key("energy_final_J").value(summary.energy_final);
    json.key("energy_max_J").value(summary.energy_max);
    json.key("kinetic_final_J").value(world.kinetic_energy());
    json.key("elastic_final_J").value(world.elastic_energy());
    write_vec(json, "linear_momentum_initial", summary.momentum_initial);
    write_vec(json, "linear_momentum_final", summary.momentum_final);
    write_vec(json, "angular_momentum_initial", summary.angular_initial);
    write_vec(json, "angular_momentum_final", summary.angular_final);
    json.key("fragments").value(static_cast<std::uint64_t>(world.fragment_count()));
    json.key("splits").value(static_cast<std::uint64_t>(summary.splits));
    json.key("exposed_faces_new").value(static_cast<std::uint64_t>(summary.exposed));
    json.key("contacts").value(static_cast<std::uint64_t>(summary.contacts));
    json.key("contacts_swept_only").value(static_cast<std::uint64_t>(summary.swept));
    json.key("contact_response_iterations").value(static_cast<std::uint64_t>(summary.response_iterations));
    json.key("sphere_penetration_max_m").value(summary.sphere_penetration_max);
    json.key("sphere_penetration_final_m").value(summary.sphere_penetration_final);
    json.key("vertex_penetration_max_m").value(summary.vertex_penetration_max);
    json.key("vertex_penetration_final_m").value(summary.vertex_penetration_final);
    json.key("solver_iterations_mean").value(static_cast<double>(summary.iterations) * per_step / 1e3);
    json.key("factorizations").value(static_cast<std::int64_t>(summary.factorizations));
    json.key("steps_at_iteration_cap").value(static_cast<std::uint64_t>(summary.unconverged));
    json.key("substeps_max").value(summary.substeps_max);
    json.end_object();
    json.end_object();
    const std::filesystem::path temporary = options.report.string() + ".tmp";
    {
      std::ofstream out(temporary);
      out << json.str() << '\n';
      if (!out) throw Error(options.report.string() + ": cannot write the report", "check the folder exists and is writable");
    }
    std::filesystem::rename(temporary, options.report);
    std::printf("report     %s\n", options.report.string().c_str());
  }
  if (recording) {
    for (std::size_t b = 0; b < world.bodies().size(); ++b) {
      split_from[b].resize(world.bodies()[b].integrator().node_count(), kInvalidIndex);
      trajectory.bodies[b].split_from = split_from[b];
    }
    formats::write_trajectory(options.trajectory, trajectory);
    std::printf("trajectory %s (%zu frames)\n", options.trajectory.string().c_str(), trajectory.time.size());
  }
  return 0;
}

}  // namespace fissure::player
