#pragma once
/// The player's loop (docs/architecture.md, "The player"): physics at
/// the scene's fixed dt, decoupled from frames by an accumulator, with observers that
/// watch it (report, trajectory, diagnostics; frames when the renderer comes). An
/// observer costs nothing when it is not added. A step that fails stops the loop and is
/// reported to every observer; the world is left as it was before that step.

#include <chrono>
#include <optional>
#include <string>
#include <vector>

#include "player/sim/world.h"

namespace fissure::player {

/// An observer's reason to stop a run that the world itself took as fine (a
/// non-finite energy, later an energy bound broken).
struct RunStop {
  std::string message;
  std::string hint;
};

/// How a run ended.
struct RunEnd {
  long steps = 0;               ///< physics steps taken
  sim::StepStatus status;       ///< the failed step's status, or an ok one
  std::optional<RunStop> stop;  ///< set when an observer stopped the run
  double wall_seconds = 0;      ///< stepping time, observers included
  [[nodiscard]] bool ok() const { return status.ok() && !stop; }
};

class RunObserver {
 public:
  virtual ~RunObserver() = default;
  virtual void on_start(const sim::World& /*world*/) {}
  /// After each successful step; `step` counts from 1.
  virtual void on_step(const sim::World& /*world*/, const sim::StepReport& /*report*/, long /*step*/) {}
  /// When stepping ends: `end.status` says whether the last step failed.
  virtual void on_finish(const sim::World& /*world*/, const RunEnd& /*end*/) {}
  /// Asked after every step: a reason to stop the run now, or null.
  [[nodiscard]] virtual const RunStop* stop_request() const { return nullptr; }
};

/// What advance() did for one frame.
struct FrameAdvance {
  int steps = 0;       ///< physics steps taken for this frame
  /// Frame time left in the accumulator, in steps, in [0, 1): a frame may draw
  /// previous + alpha (current − previous) (BodyFrame), one step behind but smooth.
  double alpha = 0;
  bool dropped = false;  ///< the frame needed more than max_steps_per_frame: the rest of its time was dropped
  bool failed = false;   ///< a step failed: the loop has stopped (see end())
};

class RunLoop {
 public:
  explicit RunLoop(sim::World& world);

  /// Observers are called in the order added; they must outlive the loop's runs.
  void add(RunObserver& observer) { m_observers.push_back(&observer); }

  /// Takes `steps` physics steps, or fewer if one fails.
  RunEnd run_steps(long steps);

  /// Frame-driven: adds `seconds` of frame time to the accumulator and takes as many
  /// whole steps of dt as fit (at most max_steps_per_frame; more is dropped, so a slow
  /// frame cannot make the next one slower). start() first, finish() at the end.
  void start();
  FrameAdvance advance(double seconds, int max_steps_per_frame = 64);
  /// Takes up to `steps` steps (after start()); returns how many it took (fewer when one fails).
  long take_steps(long steps);
  RunEnd finish();

  [[nodiscard]] bool stopped() const { return !m_end.ok(); }
  [[nodiscard]] const RunEnd& end() const { return m_end; }

 private:
  bool step_once();

  using Clock = std::chrono::steady_clock;
  sim::World& m_world;
  std::vector<RunObserver*> m_observers;
  double m_accumulator = 0;
  RunEnd m_end;
  Clock::time_point m_start;
};

}  // namespace fissure::player
