// cloth_node's ~step service: a call is cut into chunks of frames that run on the node's own callback
// queue (the spin thread, between timer ticks), while the service's thread waits for the last one; a
// second call waits its turn. Declared in cloth_node.h.
#include "cloth_sim/ros/cloth_node.h"

#include "cloth_sim/core/constants.h"
#include "cloth_sim/ros/shutdown.h"

#include <boost/make_shared.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iomanip>
#include <memory>
#include <mutex>
#include <sstream>
#include <string>

namespace cloth_sim {

namespace {

using core::kMillisecondsPerSecond;
/// How often a service thread waiting for its ~step looks whether the node is shutting down.
constexpr std::chrono::milliseconds kStepWaitPoll{100};

}  // namespace

/// Runs one chunk of a ~step job on the node's callback queue (the spin thread).
class ClothNode::StepChunk : public ros::CallbackInterface {
 public:
  StepChunk(ClothNode* node, std::shared_ptr<StepJob> job) : node_(node), job_(std::move(job)) {}
  CallResult call() override {
    node_->runStepChunk(job_);
    return Success;
  }

 private:
  ClothNode* node_;
  std::shared_ptr<StepJob> job_;
};

bool ClothNode::onStep(cloth_sim::Step::Request& request, cloth_sim::Step::Response& response) {
  auto job = std::make_shared<StepJob>();
  job->frames = request.frames;
  queueStepChunk(job);
  std::unique_lock<std::mutex> lock(step_mutex_);
  while (!job->done) {
    // Woken now and then to notice a shutdown: the spin thread stops running chunks then.
    if (!ros::ok() || step_stopping_) {
      response.success = false;
      response.message = "the node is shutting down";
      return true;
    }
    step_done_.wait_for(lock, kStepWaitPoll);
  }
  response = job->response;
  return true;
}

void ClothNode::queueStepChunk(const std::shared_ptr<StepJob>& job) {
  pnh_.getCallbackQueue()->addCallback(boost::make_shared<StepChunk>(this, job),
                                       reinterpret_cast<std::uint64_t>(this));
}

std::string ClothNode::refuseStep(const StepJob& job) const {
  if (!paused_) return "not paused: call ~pause with data=true first";
  // The step service's one thread takes its calls one after another, each waiting for its answer, so a
  // job is still under way here only if its call stopped waiting (the node shutting down).
  if (active_step_) return "another ~step is in progress";
  if (job.frames == 0 || job.frames > kMaxStepFrames) {
    return "frames = " + std::to_string(job.frames) + ": must be in [1, " + std::to_string(kMaxStepFrames) + "]";
  }
  return stepOverBudget(job.frames);
}

std::string ClothNode::stepOverBudget(std::uint64_t frames) const {
  // The last frame's cost is the estimate (none yet: the call's first frame gives one, runStepChunk).
  const double frame_cost_s = step_cost_ms_ / kMillisecondsPerSecond;
  if (frame_cost_s <= 0.0) return "";
  const double most_frames = std::max(1.0, std::floor(kMaxStepWork_s / frame_cost_s));
  if (static_cast<double>(frames) <= most_frames) return "";
  std::ostringstream reason;
  reason << std::fixed << std::setprecision(1) << "frames = " << frames << " would take about "
         << std::lround(static_cast<double>(frames) * frame_cost_s) << " s at " << step_cost_ms_
         << " ms per frame (the last frame's cost); one call may take at most " << kMaxStepWork_s
         << " s: ask for at most " << static_cast<std::uint64_t>(most_frames) << " frames per call";
  return reason.str();
}

void ClothNode::runStepChunk(const std::shared_ptr<StepJob>& job) {
  if (!job->started) {
    const std::string refusal = refuseStep(*job);
    if (!refusal.empty()) {
      answerStep(*job, false, refusal);
      return;
    }
    job->started = true;
    job->unestimated = step_cost_ms_ <= 0.0;
    job->start_time = std::chrono::steady_clock::now();
    active_step_ = job;
  }
  if (active_step_ != job) return;  // cancelled (and answered) while this chunk waited in the queue
  const auto overrun = std::chrono::duration<double>(kMaxStepWork_s * kStepOverrunFactor);
  const auto chunk_end = std::chrono::steady_clock::now() + std::chrono::duration<double>(kStepChunk_s);
  while (job->frames_done < job->frames) {
    const auto now = std::chrono::steady_clock::now();
    if (!ros::ok() || shutdownSignalled()) {
      cancelStep("the node is shutting down" + (shutdownSignalled() ? " (" + shutdownSignalName() + ")" : std::string()));
      return;
    }
    if (now - job->start_time > overrun) {
      std::ostringstream reason;
      reason << "the call ran past " << kMaxStepWork_s * kStepOverrunFactor << " s, " << kStepOverrunFactor
             << " times the " << kMaxStepWork_s << " s a call may be expected to take";
      cancelStep(reason.str());
      return;
    }
    if (now >= chunk_end) {
      queueStepChunk(job);  // the rest after the callbacks queued meanwhile
      return;
    }
    if (!advanceFrames(1)) {
      finishStep(false, "stopped after " + std::to_string(job->frames_done) + " frames: " + last_report_.reason);
      return;
    }
    ++job->frames_done;
    if (job->unestimated) {
      // After a scene change the call came with no cost to estimate from: its first frame's is checked
      // against the frames left, as the call itself would have been.
      job->unestimated = false;
      const std::string over = stepOverBudget(job->frames - job->frames_done);
      if (!over.empty()) {
        finishStep(false, "stopped after 1 frames (the first since the scene changed, so the call could not be "
                          "estimated before): the rest, " + over);
        return;
      }
    }
  }
  finishStep(true, "advanced " + std::to_string(job->frames) + " frames");
}

void ClothNode::answerStep(StepJob& job, bool success, const std::string& message) {
  std::lock_guard<std::mutex> lock(step_mutex_);
  job.response.success = success;
  job.response.message = message;
  job.response.sim_time = simulation_->state().time_s;
  job.done = true;
  step_done_.notify_all();
}

void ClothNode::finishStep(bool success, const std::string& message) {
  if (ros::ok()) publish(ros::Time::now());
  answerStep(*active_step_, success, message);
  active_step_.reset();
}

void ClothNode::cancelStep(const std::string& reason) {
  if (!active_step_) return;
  finishStep(false, "stopped after " + std::to_string(active_step_->frames_done) + " frames: " + reason);
}

}  // namespace cloth_sim
