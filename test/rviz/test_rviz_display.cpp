// The cloth_sim/ClothState display drawing in a real rviz window: config/cloth.rviz loaded in an
// rviz::VisualizationFrame on a display server of the test's own (Xvfb, software GL), fed ClothState
// messages on /cloth_node/state, its statuses read back and its window captured. Each case was found by an
// audit of the viewing path (doc/RELIABILITY.md): rviz aborting on a coordinate infinite as a float, a mask
// with no triangle drawn as garbage, a Transform error that never cleared, a property change that did not
// redraw a paused cloth. Run by test/ros/rviz_display.test, whose master the display's subscriber needs.
#include "cloth_sim/ClothState.h"

#include <OGRE/OgreRenderWindow.h>
#include <QApplication>
#include <QImage>
#include <ros/package.h>
#include <ros/ros.h>
#include <rviz/display.h>
#include <rviz/display_group.h>
#include <rviz/properties/status_property.h>
#include <rviz/render_panel.h>
#include <rviz/visualization_frame.h>
#include <rviz/visualization_manager.h>

#include <gtest/gtest.h>
#include <signal.h>
#include <poll.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <memory>
#include <string>
#include <thread>

namespace {

constexpr int kSide = 20;
constexpr double kSpacing_m = 0.05;
/// How long a case may wait for rviz (software GL on a loaded 2-core machine), s.
constexpr double kDeadline_s = 30.0;
/// The virtual screen, and how long Xvfb may take to accept connections.
constexpr const char* kScreen = "800x600x24";
constexpr int kXvfbStartTimeout_ms = 20000;
/// How often the test publishes while it waits, and how long each turn of rviz's event loop may take.
constexpr std::chrono::milliseconds kPublishPeriod{100};
constexpr int kEventLoopTurn_ms = 20;
constexpr std::chrono::milliseconds kLoopPause{10};
/// Window captures this far apart that are the same: the cloth has been drawn and nothing moves.
constexpr double kSettle_s = 0.5;
/// A repaint of the cloth changes at least this many pixels (its dark checker squares: about a third of
/// its 20 x 20 cells, thousands of pixels in the 800 x 600 window).
constexpr int kRepaintedPixels = 1000;
/// The forked child's exit status when Xvfb cannot be run.
constexpr int kExecFailed = 127;
/// Pixels whose colour changed by more than this (of 255, in any channel) count as repainted.
constexpr int kChangedLevel = 30;

/// Xvfb on a display number it picks itself (-displayfd: it writes the number once it accepts
/// connections), DISPLAY set to it; stopped with the test process, even when that is aborted.
class DisplayServer {
 public:
  bool start() {
    int ready[2];
    if (pipe(ready) != 0) return false;
    const std::string fd = std::to_string(ready[1]);
    char* argv[] = {const_cast<char*>("Xvfb"), const_cast<char*>("-displayfd"), const_cast<char*>(fd.c_str()),
                    const_cast<char*>("-screen"), const_cast<char*>("0"), const_cast<char*>(kScreen),
                    const_cast<char*>("-nolisten"), const_cast<char*>("tcp"), nullptr};
    const pid_t parent = getpid();
    pid_ = fork();
    if (pid_ < 0) return false;
    if (pid_ == 0) {
      close(ready[0]);
      // Ends with the test even when rviz aborts it (the defect this test looks for did).
      prctl(PR_SET_PDEATHSIG, SIGTERM);
      if (getppid() != parent) _exit(kExecFailed);
      execvp("Xvfb", argv);
      _exit(kExecFailed);
    }
    close(ready[1]);
    std::string number;
    pollfd wait{ready[0], POLLIN, 0};
    char c = 0;
    while (poll(&wait, 1, kXvfbStartTimeout_ms) == 1 && read(ready[0], &c, 1) == 1 && c != '\n') number += c;
    close(ready[0]);
    if (number.empty()) {
      stop();
      return false;
    }
    setenv("DISPLAY", (":" + number).c_str(), 1);
    return true;
  }
  void stop() {
    if (pid_ <= 0) return;
    kill(pid_, SIGTERM);
    waitpid(pid_, nullptr, 0);
    pid_ = -1;
  }
  ~DisplayServer() { stop(); }

 private:
  pid_t pid_ = -1;
};

cloth_sim::ClothState flatCloth() {
  cloth_sim::ClothState message;
  message.header.frame_id = "world";
  message.rows = kSide;
  message.cols = kSide;
  for (int r = 0; r < kSide; ++r) {
    for (int c = 0; c < kSide; ++c) {
      geometry_msgs::Point p;
      p.x = c * kSpacing_m;
      p.z = 1.0 - r * kSpacing_m;
      message.positions.push_back(p);
    }
  }
  return message;
}

/// The display's status entry `name` ("Message", "Transform"), or null when it has none.
rviz::StatusProperty* statusOf(rviz::Display* display, const std::string& name) {
  for (int i = 0; i < display->numChildren(); ++i) {
    rviz::Property* list = display->childAt(i);
    for (int j = 0; j < list->numChildren(); ++j) {
      auto* status = dynamic_cast<rviz::StatusProperty*>(list->childAt(j));
      if (status != nullptr && status->getName().toStdString() == name) return status;
    }
  }
  return nullptr;
}

class RvizWindow {
 public:
  RvizWindow(QApplication& app, rviz::VisualizationFrame& frame) : app_(app), frame_(frame) {
    state_pub_ = handle_.advertise<cloth_sim::ClothState>("/cloth_node/state", 1);
    rviz::DisplayGroup* root = frame_.getManager()->getRootDisplayGroup();
    for (int i = 0; i < root->numDisplays(); ++i) {
      if (root->getDisplayAt(i)->getName() == "Cloth") display_ = root->getDisplayAt(i);
    }
  }

  rviz::Display* display() const { return display_; }

  /// Runs rviz's event loop, publishing `message` (if given) every tenth of a second, until `done`; false
  /// if it never is within kDeadline_s.
  bool runUntil(const std::function<bool()>& done, const cloth_sim::ClothState* message = nullptr) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(kDeadline_s);
    auto next_publish = std::chrono::steady_clock::now();
    while (std::chrono::steady_clock::now() < deadline) {
      if (message != nullptr && std::chrono::steady_clock::now() >= next_publish) {
        state_pub_.publish(*message);
        next_publish += kPublishPeriod;
      }
      app_.processEvents(QEventLoop::AllEvents, kEventLoopTurn_ms);
      if (done()) return true;
      std::this_thread::sleep_for(kLoopPause);
    }
    return false;
  }

  /// Runs the event loop for `seconds` without publishing.
  void idle(double seconds) {
    const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
    runUntil([until] { return std::chrono::steady_clock::now() >= until; });
  }

  bool messageSays(rviz::StatusProperty::Level level, const std::string& text) const {
    rviz::StatusProperty* status = statusOf(display_, "Message");
    return status != nullptr && status->getLevel() == level &&
           status->getValue().toString().toStdString().find(text) != std::string::npos;
  }

  QImage capture(const std::string& name) {
    Ogre::RenderWindow* window = frame_.getManager()->getRenderPanel()->getRenderWindow();
    window->update();
    const std::string path = "/tmp/cloth_sim_rviz_display_" + std::to_string(getpid()) + "_" + name + ".png";
    window->writeContentsToFile(path);
    QImage image(QString::fromStdString(path));
    std::remove(path.c_str());
    return image.convertToFormat(QImage::Format_RGB32);
  }

 private:
  QApplication& app_;
  rviz::VisualizationFrame& frame_;
  ros::NodeHandle handle_;
  ros::Publisher state_pub_;
  rviz::Display* display_ = nullptr;
};

int changedPixels(const QImage& a, const QImage& b) {
  if (a.size() != b.size()) return -1;
  int changed = 0;
  for (int y = 0; y < a.height(); ++y) {
    for (int x = 0; x < a.width(); ++x) {
      const QRgb p = a.pixel(x, y);
      const QRgb q = b.pixel(x, y);
      if (std::abs(qRed(p) - qRed(q)) > kChangedLevel || std::abs(qGreen(p) - qGreen(q)) > kChangedLevel ||
          std::abs(qBlue(p) - qBlue(q)) > kChangedLevel) {
        ++changed;
      }
    }
  }
  return changed;
}

}  // namespace

TEST(RvizDisplay, DrawsWhatItCanSaysWhyNotAndRedrawsOnAPropertyChange) {
  DisplayServer server;
  ASSERT_TRUE(server.start()) << "could not start Xvfb (make deps installs it)";
  int argc = 1;
  char name[] = "test_rviz_display";
  char* argv[] = {name, nullptr};
  QApplication app(argc, argv);
  auto frame = std::make_unique<rviz::VisualizationFrame>();
  frame->setSplashPath("");
  frame->initialize(QString::fromStdString(ros::package::getPath("cloth_sim") + "/config/cloth.rviz"));
  frame->show();
  RvizWindow rviz(app, *frame);
  ASSERT_NE(rviz.display(), nullptr) << "config/cloth.rviz has no display named Cloth";
  const auto says = [&rviz](rviz::StatusProperty::Level level, const std::string& text) {
    return [&rviz, level, text] { return rviz.messageSays(level, text); };
  };

  cloth_sim::ClothState good = flatCloth();
  ASSERT_TRUE(rviz.runUntil(says(rviz::StatusProperty::Ok, "20 x 20 particles"), &good));

  // Finite as a double, infinite as the float rviz draws with: rviz aborted (SIGABRT) in Ogre.
  cloth_sim::ClothState huge = flatCloth();
  huge.positions[5].z = 1e39;
  EXPECT_TRUE(rviz.runUntil(says(rviz::StatusProperty::Error, "position 5 is not finite or beyond"), &huge));
  EXPECT_TRUE(rviz.runUntil(says(rviz::StatusProperty::Ok, "20 x 20 particles"), &good));

  // No particle active: no triangle to draw (Ogre drew the bare vertex list across the grid, status OK).
  cloth_sim::ClothState none = flatCloth();
  none.active.assign(static_cast<std::size_t>(kSide) * kSide, 0);
  EXPECT_TRUE(rviz.runUntil(says(rviz::StatusProperty::Warn, "no triangle among the active ones"), &none));

  // A frame rviz cannot look up, then the right one: the Transform error goes once the cloth is drawn again.
  // ("/world": tf2 refuses a frame name with a leading slash, so the display itself reports it.)
  cloth_sim::ClothState slash = flatCloth();
  slash.header.frame_id = "/world";
  const auto transform_error = [&rviz] {
    rviz::StatusProperty* status = statusOf(rviz.display(), "Transform");
    return status != nullptr && status->getLevel() == rviz::StatusProperty::Error;
  };
  EXPECT_TRUE(rviz.runUntil(transform_error, &slash));
  EXPECT_TRUE(rviz.runUntil(says(rviz::StatusProperty::Ok, "20 x 20 particles"), &good));
  EXPECT_TRUE(rviz.runUntil([&] { return !transform_error(); }, &good)) << "the Transform error stayed";

  // No message arrives any more (a paused bag): Checker off must repaint the cloth in one colour. First
  // the window as it settles (two captures alike), then a wait for the repaint.
  QImage checkered = rviz.capture("checkered");
  ASSERT_TRUE(rviz.runUntil([&] {
    rviz.idle(kSettle_s);
    const QImage next = rviz.capture("checkered");
    const bool settled = changedPixels(checkered, next) == 0;
    checkered = next;
    return settled;
  }));
  ASSERT_FALSE(checkered.isNull());
  rviz.display()->subProp("Checker")->setValue(false);
  EXPECT_TRUE(rviz.runUntil([&] { return changedPixels(checkered, rviz.capture("plain")) > kRepaintedPixels; }))
      << "the paused cloth was not redrawn";

  frame.reset();  // before the display server goes
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_rviz_display", ros::init_options::AnonymousName);
  return RUN_ALL_TESTS();
}
