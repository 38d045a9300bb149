// An rviz display that draws a cloth_sim/ClothState as a lit, indexed triangle mesh, so that neither the
// node nor a bag needs the heavy ~mesh marker (at 128x128 the marker is 4.7 MB a frame, each vertex six
// times with a colour; the state is 0.8 MB, each particle once). Triangles and colours are built once per
// grid size; each message only refills the vertex positions and normals.
#pragma once

#include "cloth_sim/ClothState.h"

#include <rviz/message_filter_display.h>

#include <OGRE/OgreColourValue.h>
#include <OGRE/OgreMaterial.h>

#include <Eigen/Core>
#include <Eigen/Geometry>  // cross()

#include <cstdint>
#include <vector>

namespace Ogre {
class ManualObject;
}

namespace rviz {
class BoolProperty;
class ColorProperty;
class FloatProperty;
}  // namespace rviz

namespace cloth_sim {

class ClothStateDisplay : public rviz::MessageFilterDisplay<cloth_sim::ClothState> {
  Q_OBJECT
 public:
  ClothStateDisplay();
  ~ClothStateDisplay() override;

 protected:
  void onInitialize() override;
  void reset() override;
  /// Keeps the newest message only: it is drawn in update(), once per rendered frame, so a 50 Hz topic
  /// costs rviz at most its frame rate's worth of mesh updates.
  void processMessage(const cloth_sim::ClothState::ConstPtr& message) override;
  void update(float wall_dt, float ros_dt) override;

 private Q_SLOTS:
  void updateAppearance();

 private:
  /// Draws the message, or says in the status why not (false: nothing changed on screen). A redraw (the
  /// same message again, after a property change) is placed with the frame's newest transform.
  bool draw(const cloth_sim::ClothState& message, bool redraw);
  /// The colour of every particle: the node's default checker (as cloth_viewer draws it) or one colour.
  void computeColours(int rows, int cols);
  /// Fills the ManualObject: both faces of every quad, the back with reversed winding and flipped normals
  /// (so each side is lit as itself), one index buffer per face.
  void fillMesh(const std::vector<Eigen::Vector3f>& positions_m, const std::vector<Eigen::Vector3f>& normals);

  cloth_sim::ClothState::ConstPtr pending_;  ///< received, not drawn yet
  /// The newest message, when it was drawn (null when it was refused): drawn again when a property changes.
  cloth_sim::ClothState::ConstPtr drawn_;
  Ogre::ManualObject* mesh_ = nullptr;
  Ogre::MaterialPtr material_;
  rviz::BoolProperty* checker_property_ = nullptr;
  rviz::ColorProperty* color_property_ = nullptr;
  rviz::FloatProperty* alpha_property_ = nullptr;
  int rows_ = 0;
  int cols_ = 0;
  bool mesh_built_ = false;  ///< the ManualObject's section exists for rows_ x cols_
  std::vector<Ogre::ColourValue> colours_;
  std::vector<std::uint8_t> active_;    ///< the particles that are cloth (ClothState::active; empty: all)
  std::vector<std::uint32_t> indices_;  ///< front-face triangles, counter-clockwise seen along +normal
};

}  // namespace cloth_sim
