#include "player/app/run_report.h"

#include <algorithm>
#include <cstdio>

#include "common/error.h"
#include "common/json_writer.h"
#include "common/output_file.h"

namespace fissure::player {

namespace {

const char* solver_name(const sim::WorldSettings& s) {
  if (s.step.solver == sim::LinearSolver::Direct) return "direct (CHOLMOD supernodal Cholesky)";
  return s.step.preconditioner == sim::Preconditioner::Jacobi ? "conjugate gradients (Jacobi)"
                                                              : "conjugate gradients (lagged Cholesky)";
}

double per_step(double total, long steps) { return total / static_cast<double>(std::max(steps, 1L)); }

void write_vec(JsonWriter& json, const char* name, const Vec3& v) {
  json.key(name).begin_array().value(v.x()).value(v.y()).value(v.z()).end_array();
}

void write_phase(JsonWriter& json, const char* name, const PhaseStats& p, long steps) {
  json.key(name).begin_object();
  json.key("mean_ms").value(1e3 * per_step(p.total, steps));
  json.key("p99_ms").value(1e3 * p.quantile(0.99));
  json.key("max_ms").value(1e3 * p.max);
  json.key("total_s").value(p.total);
  json.end_object();
}

void write_slowest_steps(JsonWriter& json, const std::vector<SlowStep>& slowest) {
  json.key("slowest_steps").begin_array();
  for (const SlowStep& s : slowest) {
    json.begin_object();
    json.key("step").value(static_cast<std::int64_t>(s.step));
    json.key("ms").value(1e3 * s.total);
    json.key("solve_ms").value(1e3 * s.solve);
    json.key("collisions_ms").value(1e3 * s.collisions);
    json.key("fracture_ms").value(1e3 * s.fracture);
    json.key("guard_ms").value(1e3 * s.guard);
    json.key("substeps").value(s.substeps);
    json.key("exact_substeps").value(s.exact_substeps);
    json.key("energy_halvings").value(s.energy_halvings);
    json.key("factorizations").value(s.factorizations);
    json.key("retaken_to_wake").value(s.retaken_to_wake);
    json.key("splits").value(static_cast<std::uint64_t>(s.splits));
    json.end_object();
  }
  json.end_array();
}

void write_bodies(JsonWriter& json, const sim::World& world, const RunRecord& run) {
  json.key("bodies").begin_array();
  for (std::size_t b = 0; b < world.bodies().size(); ++b) {
    const sim::Body& body = world.bodies()[b];
    json.begin_object();
    json.key("name").value(body.name);
    json.key("bundle").value(run.bundles[b]);
    json.key("tets").value(static_cast<std::uint64_t>(body.integrator().elasticity().tet_count()));
    json.key("nodes_initial").value(static_cast<std::uint64_t>(run.statistics->initial_nodes[b]));
    json.key("nodes_final").value(static_cast<std::uint64_t>(body.integrator().node_count()));
    json.key("spheres").value(static_cast<std::uint64_t>(body.spheres.size()));
    json.key("render_vertices").value(static_cast<std::uint64_t>(body.vertices.size()));
    json.key("fragments").value(static_cast<std::uint64_t>(body.topology.fragment_count()));
    json.key("exposed_faces").value(static_cast<std::uint64_t>(body.topology.exposed_face_count()));
    json.end_object();
  }
  json.end_array();
}

void write_timings(JsonWriter& json, const RunRecord& run) {
  const RunStatistics& s = *run.statistics;
  const long steps = run.end.steps;
  json.key("timings").begin_object();
  write_phase(json, "forces", s.forces, steps);
  write_phase(json, "assembly", s.assembly, steps);
  write_phase(json, "solve", s.solve, steps);
  write_phase(json, "fracture", s.fracture, steps);
  write_phase(json, "collisions", s.collisions, steps);
  write_phase(json, "guard", s.guard, steps);
  write_phase(json, "step", s.step, steps);
  write_slowest_steps(json, s.slowest);
  if (run.diagnostics != nullptr) json.key("diagnostics_total_s").value(run.diagnostics->seconds);
  json.end_object();
}

void write_status(JsonWriter& json, const sim::World& world, const RunEnd& end) {
  json.key("status").begin_object();
  if (end.stop) {
    json.key("outcome").value("stopped");
    json.key("message").value(end.stop->message);
    json.key("hint").value(end.stop->hint);
  } else {
    json.key("outcome").value(end.status.ok() ? "completed" : sim::to_string(end.status.outcome));
  }
  if (!end.status.ok()) {
    const sim::StepFailure failure = world.explain(end.status);
    json.key("message").value(failure.message);
    json.key("hint").value(failure.hint);
    json.key("time_s").value(end.status.time);
    json.key("dt_s").value(end.status.dt);
    json.key("body").value(end.status.body < world.bodies().size() ? world.bodies()[end.status.body].name : "");
  }
  json.end_object();
}

void write_diagnostics(JsonWriter& json, const Diagnostics& d) {
  json.key("energy_initial_J").value(d.energy_initial);
  json.key("energy_final_J").value(d.energy_final);
  json.key("energy_max_J").value(d.energy_max);
  json.key("energy_put_in_J").value(d.energy_put_in);
  json.key("energy_gain").value(d.energy_gain);
  json.key("kinetic_final_J").value(d.kinetic_final);
  json.key("elastic_final_J").value(d.elastic_final);
  write_vec(json, "linear_momentum_initial", d.momentum_initial);
  write_vec(json, "linear_momentum_final", d.momentum_final);
  write_vec(json, "angular_momentum_initial", d.angular_initial);
  write_vec(json, "angular_momentum_final", d.angular_final);
}

void write_summary(JsonWriter& json, const sim::World& world, const RunRecord& run) {
  const RunStatistics& s = *run.statistics;
  json.key("summary").begin_object();
  if (run.diagnostics != nullptr) write_diagnostics(json, *run.diagnostics);
  json.key("fragments").value(static_cast<std::uint64_t>(world.fragment_count()));
  json.key("splits").value(static_cast<std::uint64_t>(s.splits));
  json.key("exposed_faces_new").value(static_cast<std::uint64_t>(s.exposed));
  json.key("stand_in_spheres").value(static_cast<std::uint64_t>(s.stand_in_spheres));
  json.key("contacts").value(static_cast<std::uint64_t>(s.contacts));
  json.key("contacts_swept_only").value(static_cast<std::uint64_t>(s.swept));
  json.key("contact_response_iterations").value(static_cast<std::uint64_t>(s.response_iterations));
  json.key("contact_response_sweeps").value(static_cast<std::uint64_t>(s.response_sweeps));
  json.key("contact_rigid_answers").value(static_cast<std::uint64_t>(s.rigid_answers));
  json.key("restitution_limited_steps").value(static_cast<std::uint64_t>(s.restitution_limited));
  json.key("restitution_kept_min").value(s.restitution_kept_min);
  json.key("exact_substeps").value(static_cast<std::uint64_t>(s.exact_substeps));
  json.key("exact_newton_iterations").value(static_cast<std::uint64_t>(s.exact_iterations));
  json.key("exact_substeps_rejected").value(static_cast<std::uint64_t>(s.exact_rejected));
  json.key("energy_halvings").value(static_cast<std::uint64_t>(s.energy_halvings));
  json.key("chips_moved_rigidly").value(static_cast<std::uint64_t>(s.chips_moved_rigidly));
  json.key("fragments_asleep_final").value(static_cast<std::uint64_t>(s.fragments_asleep));
  json.key("steps_retaken_to_wake").value(static_cast<std::uint64_t>(s.retaken_to_wake));
  if (run.diagnostics != nullptr) {
    json.key("sphere_penetration_max_m").value(run.diagnostics->sphere_penetration_max);
    json.key("sphere_penetration_final_m").value(run.diagnostics->sphere_penetration_final);
    json.key("vertex_penetration_max_m").value(run.diagnostics->vertex_penetration_max);
    json.key("vertex_penetration_final_m").value(run.diagnostics->vertex_penetration_final);
    json.key("vertex_penetration_where").value(run.diagnostics->vertex_penetration_where);
  }
  json.key("solver_iterations_mean").value(per_step(static_cast<double>(s.iterations), run.end.steps));
  json.key("factorizations").value(static_cast<std::int64_t>(s.factorizations));
  json.key("steps_at_iteration_cap").value(static_cast<std::uint64_t>(s.unconverged));
  json.key("substeps_max").value(s.substeps_max);
  json.end_object();
}

}  // namespace

void print_summary(const sim::World& world, const RunRecord& run) {
  const RunStatistics& s = *run.statistics;
  const long steps = run.end.steps;
  std::printf("%ld steps of %.6g s (%.4g s simulated) in %.3f s wall\n", steps, world.settings().step.dt, world.time(),
              run.end.wall_seconds);
  std::printf("phase        mean ms    p99 ms    max ms\n");
  const std::pair<const char*, const PhaseStats*> rows[] = {
      {"forces", &s.forces},         {"assembly", &s.assembly},     {"solve", &s.solve},
      {"fracture", &s.fracture},     {"collisions", &s.collisions}, {"guard", &s.guard},
      {"step", &s.step}};
  for (const auto& [name, p] : rows) {
    std::printf("%-10s %9.3f %9.3f %9.3f\n", name, 1e3 * per_step(p->total, steps), 1e3 * p->quantile(0.99), 1e3 * p->max);
  }
  if (const Diagnostics* d = run.diagnostics; d != nullptr) {
    std::printf("energy     %.6g J -> %.6g J (max %.6g J; kinetic + elastic + gravity), %.6g J put in\n",
                d->energy_initial, d->energy_final, d->energy_max, d->energy_put_in);
    if (!d->energy_gain.empty() && run.end.ok()) std::printf("warning    %s\n", d->energy_gain.c_str());
    std::printf("momentum   |p| %.6g -> %.6g kg m/s, |L| %.6g -> %.6g kg m²/s\n", d->momentum_initial.norm(),
                d->momentum_final.norm(), d->angular_initial.norm(), d->angular_final.norm());
  }
  std::printf("fracture   %zu splits, %zu faces exposed, %u fragments", s.splits, s.exposed, world.fragment_count());
  if (s.stand_in_spheres > 0) std::printf("; %zu spheres added to exposed tets (stand-ins, reserve)", s.stand_in_spheres);
  if (world.settings().sleep.speed > 0.0) {
    std::printf("; %zu asleep at the end, %zu steps taken again to wake one", s.fragments_asleep, s.retaken_to_wake);
  }
  std::printf("\n");
  std::printf("contacts   %zu (%zu caught only by swept tests)", s.contacts, s.swept);
  if (run.diagnostics != nullptr) {
    std::printf(", penetration max: spheres %.3g m, render vertices %.3g m", run.diagnostics->sphere_penetration_max,
                run.diagnostics->vertex_penetration_max);
    if (!run.diagnostics->vertex_penetration_where.empty()) {
      std::printf(" (%s)", run.diagnostics->vertex_penetration_where.c_str());
    }
  }
  std::printf("\nresponse  %.1f conjugate-gradient iterations/step inside the implicit step",
              per_step(static_cast<double>(s.response_iterations), steps));
  if (s.response_sweeps > 0) {
    std::printf(", %.1f sequential-impulse sweeps/step", per_step(static_cast<double>(s.response_sweeps), steps));
  }
  if (s.rigid_answers > 0) {
    std::printf(", %.2f resting large fragments answered as rigid bodies/step",
                per_step(static_cast<double>(s.rigid_answers), steps));
  }
  if (s.restitution_limited > 0) {
    std::printf("; restitution cut in %zu steps to keep the energy (down to %.2g of it)", s.restitution_limited,
                s.restitution_kept_min);
  }
  std::printf("\n");
  std::printf("solver     %s, %.1f iterations/step, %ld factorizations, %zu steps hit the iteration cap, at most %d substeps\n",
              solver_name(world.settings()), per_step(static_cast<double>(s.iterations), steps), s.factorizations,
              s.unconverged, s.substeps_max);
  if (s.exact_substeps > 0) {
    std::printf("exact      %zu substeps solved again to convergence where they gained energy "
                "(%zu Newton iterations; %zu kept the linear answer, which ended lower)\n",
                s.exact_substeps, s.exact_iterations, s.exact_rejected);
  }
  if (s.chips_moved_rigidly > 0) {
    std::printf("rigid      %zu chips moved rigidly for a substep because they gained energy "
                "(solver.rigid_when_gaining_below)\n",
                s.chips_moved_rigidly);
  }
  if (s.energy_halvings > 0) {
    std::printf("halved     %zu substeps taken again as two halves because they still gained energy "
                "(solver.energy_halvings)\n",
                s.energy_halvings);
  }
  if (run.diagnostics != nullptr) {
    std::printf("checks     %.3f ms/step for energies and penetrations (outside the step)\n",
                1e3 * per_step(run.diagnostics->seconds, steps));
  }
}

void write_report(const std::filesystem::path& path, const sim::World& world, const RunRecord& run) {
  JsonWriter json;
  json.begin_object();
  json.key("scene").value(run.scene);
  write_status(json, world, run.end);
  json.key("steps").value(static_cast<std::int64_t>(run.end.steps));
  json.key("dt").value(world.settings().step.dt);
  json.key("simulated_seconds").value(world.time());
  json.key("wall_seconds").value(run.end.wall_seconds);
  json.key("load_seconds").value(run.load_seconds);
  json.key("solver").value(solver_name(world.settings()));
  json.key("stiffness").value(world.settings().step.stiffness == sim::StiffnessModel::Exact ? "exact" : "warped");
  json.key("collision_points")
      .value(world.settings().collision_points == sim::CollisionPoints::Spheres ? "spheres" : "render vertices");
  json.key("no_tunnelling")
      .value("swept tests: sphere-sphere time of impact, segment against the radius-grown box, half-space ground");
  write_bodies(json, world, run);
  write_timings(json, run);
  write_summary(json, world, run);
  json.end_object();
  write_file_atomically(path, json.str() + "\n");
}

}  // namespace fissure::player
