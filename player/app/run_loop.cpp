#include "player/app/run_loop.h"

namespace fissure::player {

RunLoop::RunLoop(sim::World& world) : m_world(world) {}

void RunLoop::start() {
  m_end = {};
  m_accumulator = 0;
  m_start = Clock::now();
  for (RunObserver* o : m_observers) o->on_start(m_world);
}

bool RunLoop::step_once() {
  const sim::StepReport report = m_world.step();
  if (!report.status.ok()) {
    m_end.status = report.status;
    return false;
  }
  ++m_end.steps;
  for (RunObserver* o : m_observers) o->on_step(m_world, report, m_end.steps);
  for (const RunObserver* o : m_observers) {
    if (const RunStop* stop = o->stop_request(); stop != nullptr) {
      m_end.stop = *stop;
      return false;
    }
  }
  return true;
}

RunEnd RunLoop::run_steps(long steps) {
  start();
  for (long i = 0; i < steps && step_once(); ++i) {
  }
  return finish();
}

FrameAdvance RunLoop::advance(double seconds, int max_steps_per_frame) {
  FrameAdvance frame;
  if (stopped()) {
    frame.failed = true;
    return frame;
  }
  const double dt = m_world.settings().step.dt;
  m_accumulator += seconds;
  while (m_accumulator >= dt) {
    if (frame.steps == max_steps_per_frame) {
      m_accumulator = 0;
      frame.dropped = true;
      break;
    }
    if (!step_once()) {
      frame.failed = true;
      break;
    }
    m_accumulator -= dt;
    ++frame.steps;
  }
  frame.alpha = m_accumulator / dt;
  return frame;
}

long RunLoop::take_steps(long steps) {
  long taken = 0;
  while (taken < steps && !stopped() && step_once()) ++taken;
  return taken;
}

RunEnd RunLoop::finish() {
  m_end.wall_seconds = std::chrono::duration<double>(Clock::now() - m_start).count();
  for (RunObserver* o : m_observers) o->on_finish(m_world, m_end);
  return m_end;
}

}  // namespace fissure::player
