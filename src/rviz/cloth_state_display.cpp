#include "cloth_state_display.h"

#include "cloth_sim/core/grid.h"
#include "cloth_sim/core/options.h"
#include "cloth_sim/core/simulation.h"
#include "cloth_sim/ros/drawable.h"

#include <OGRE/OgreManualObject.h>
#include <OGRE/OgreMaterialManager.h>
#include <OGRE/OgreSceneManager.h>
#include <OGRE/OgreSceneNode.h>
#include <OGRE/OgreTechnique.h>
#include <pluginlib/class_list_macros.hpp>
#include <rviz/display_context.h>
#include <rviz/frame_manager.h>
#include <rviz/properties/bool_property.h>
#include <rviz/properties/color_property.h>
#include <rviz/properties/float_property.h>

#include <algorithm>
#include <cmath>
#include <string>

namespace cloth_sim {

namespace {

/// Unit grid the checker is laid on: only its texture coordinates are used (as cloth_viewer does).
constexpr double kUnitSide_m = 1.0;
/// The default one colour: the checker's light squares.
const QColor kDefaultColour(237, 219, 158);
/// The status entry naming a frame the cloth cannot be placed in.
const QString kTransformStatus = "Transform";
/// Ogre's resource group for the material and mesh made at run time.
const std::string& resourceGroup() { return Ogre::ResourceGroupManager::DEFAULT_RESOURCE_GROUP_NAME; }

}  // namespace

ClothStateDisplay::ClothStateDisplay() {
  checker_property_ = new rviz::BoolProperty(
      "Checker", true, "Draw the node's default checker (the colours cloth_viewer gives a recorded state); off: one colour.",
      this, SLOT(updateAppearance()));
  color_property_ = new rviz::ColorProperty("Color", kDefaultColour, "The cloth's colour when Checker is off.", this,
                                            SLOT(updateAppearance()));
  alpha_property_ = new rviz::FloatProperty("Alpha", 1.0f, "Opacity, 0 to 1.", this, SLOT(updateAppearance()));
  alpha_property_->setMin(0.0f);
  alpha_property_->setMax(1.0f);
}

ClothStateDisplay::~ClothStateDisplay() {
  if (mesh_) scene_manager_->destroyManualObject(mesh_);
  if (material_) Ogre::MaterialManager::getSingleton().remove(material_->getName());
}

void ClothStateDisplay::onInitialize() {
  MFDClass::onInitialize();
  static int instance = 0;  // Ogre names must be unique among every display of this class in the process
  const std::string name = "cloth_sim_ClothStateDisplay_" + std::to_string(instance++);
  mesh_ = scene_manager_->createManualObject(name);
  mesh_->setDynamic(true);
  scene_node_->attachObject(mesh_);
  material_ = Ogre::MaterialManager::getSingleton().create(name + "_material", resourceGroup());
  material_->setReceiveShadows(false);
  Ogre::Pass* pass = material_->getTechnique(0)->getPass(0);
  pass->setLightingEnabled(true);
  // Lit by the particles' own colours: ambient and diffuse follow the vertex colour.
  pass->setVertexColourTracking(Ogre::TVC_AMBIENT | Ogre::TVC_DIFFUSE);
  updateAppearance();
}

void ClothStateDisplay::reset() {
  MFDClass::reset();
  pending_.reset();
  drawn_.reset();
  mesh_->clear();
  mesh_built_ = false;
  rows_ = cols_ = 0;
  active_.clear();
}

void ClothStateDisplay::updateAppearance() {
  color_property_->setHidden(checker_property_->getBool());
  if (!material_) return;
  Ogre::Pass* pass = material_->getTechnique(0)->getPass(0);
  const bool transparent = alpha_property_->getFloat() < 1.0f;
  pass->setSceneBlending(transparent ? Ogre::SBT_TRANSPARENT_ALPHA : Ogre::SBT_REPLACE);
  pass->setDepthWriteEnabled(!transparent);
  if (rows_ > 0) {
    computeColours(rows_, cols_);
    mesh_built_ = false;  // the colours live in the vertex buffer: rebuilt from the last message drawn
    // A paused or finished bag sends no next message: the last one drawn is drawn again, unless a newer
    // one was refused (its status stays, and the cloth keeps its colours until one is drawn).
    if (!pending_ && drawn_) pending_ = drawn_;
  }
  context_->queueRender();
}

void ClothStateDisplay::computeColours(int rows, int cols) {
  const float alpha = alpha_property_->getFloat();
  colours_.assign(static_cast<std::size_t>(rows) * cols, Ogre::ColourValue::White);
  if (checker_property_->getBool()) {
    const core::ClothGrid grid = core::buildClothGrid(rows, cols, kUnitSide_m, kUnitSide_m, Eigen::Vector3d::Zero(),
                                                      Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitY());
    const Eigen::Matrix3Xf checker = core::checkerColors(grid.uv);
    for (std::size_t i = 0; i < colours_.size(); ++i) {
      const auto column = checker.col(static_cast<Eigen::Index>(i));
      colours_[i] = Ogre::ColourValue(column.x(), column.y(), column.z(), alpha);
    }
  } else {
    Ogre::ColourValue colour = color_property_->getOgreColor();
    colour.a = alpha;
    std::fill(colours_.begin(), colours_.end(), colour);
  }
}

void ClothStateDisplay::processMessage(const cloth_sim::ClothState::ConstPtr& message) { pending_ = message; }

void ClothStateDisplay::update(float /*wall_dt*/, float /*ros_dt*/) {
  if (!pending_) return;
  const cloth_sim::ClothState::ConstPtr message = pending_;
  pending_.reset();
  // A redraw is placed where the frame is now: tf may no longer hold the old stamp (10 s of cache).
  const bool redraw = message == drawn_;
  drawn_ = draw(*message, redraw) ? message : nullptr;
}

bool ClothStateDisplay::draw(const cloth_sim::ClothState& message, bool redraw) {
  // The same rule cloth_viewer's fromStateMessage applies.
  if (const std::string why = undrawableReason(message, core::OptionLimits::kMaxGridSide); !why.empty()) {
    setStatus(rviz::StatusProperty::Error, "Message", QString::fromStdString(why + ": not drawn"));
    return false;
  }
  const std::uint32_t rows = message.rows;
  const std::uint32_t cols = message.cols;
  const std::size_t count = message.positions.size();
  std::vector<Eigen::Vector3f> positions(count);
  for (std::size_t i = 0; i < count; ++i) {
    const geometry_msgs::Point& p = message.positions[i];
    positions[i] = Eigen::Vector3f(static_cast<float>(p.x), static_cast<float>(p.y), static_cast<float>(p.z));
  }
  Ogre::Vector3 position;
  Ogre::Quaternion orientation;
  std_msgs::Header header = message.header;
  if (redraw) header.stamp = ros::Time();  // the newest transform
  if (!context_->getFrameManager()->getTransform(header, position, orientation)) {
    setStatus(rviz::StatusProperty::Error, kTransformStatus,
              QString("no transform from '%1' to '%2'")
                  .arg(QString::fromStdString(message.header.frame_id))
                  .arg(fixed_frame_));
    return false;
  }
  deleteStatus(kTransformStatus);  // set while the frame was unknown; gone once it is drawn again
  scene_node_->setPosition(position);
  scene_node_->setOrientation(orientation);

  // A particle outside the scene's outline (ClothState::active) is not cloth: frozen where it started, it
  // is in no triangle and no normal.
  const auto is_cloth = [&](std::size_t i) { return active_.empty() || active_[i] != 0; };
  if (static_cast<int>(rows) != rows_ || static_cast<int>(cols) != cols_ || message.active != active_) {
    rows_ = static_cast<int>(rows);
    cols_ = static_cast<int>(cols);
    active_ = message.active;
    computeColours(rows_, cols_);
    // The core grid's triangles, as the node's ~mesh and cloth_viewer draw them (two per quad, split
    // along the same diagonal, counter-clockwise seen from the side the normals point to): with an
    // outline, a quad that loses a corner keeps the same half here as there.
    const core::ClothGrid grid = core::buildClothGrid(rows_, cols_, kUnitSide_m, kUnitSide_m, Eigen::Vector3d::Zero(),
                                                      Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitY(), active_);
    indices_.assign(grid.triangles.begin(), grid.triangles.end());
    mesh_built_ = false;
  }
  if (indices_.empty()) {
    // Ogre draws a section with no index as its plain vertex list: garbage across the whole grid.
    mesh_->clear();
    mesh_built_ = false;
    setStatus(rviz::StatusProperty::Warn, "Message",
              QString("%1 x %2 particles, no triangle among the active ones: nothing drawn").arg(rows).arg(cols));
    context_->queueRender();
    return true;
  }
  setStatus(rviz::StatusProperty::Ok, "Message",
            QString("%1 x %2 particles, frame %3").arg(rows).arg(cols).arg(message.frame));
  // Per-particle normals from central differences along the grid (one-sided at the edges, and where a
  // neighbour is not cloth): the cross product of the column and row directions, the same orientation as
  // the triangles above.
  std::vector<Eigen::Vector3f> normals(count);
  for (int r = 0; r < rows_; ++r) {
    for (int c = 0; c < cols_; ++c) {
      const auto at = [&](int rr, int cc) {
        const std::size_t i = static_cast<std::size_t>(rr * cols_ + cc);
        return positions[is_cloth(i) ? i : static_cast<std::size_t>(r * cols_ + c)];
      };
      const Eigen::Vector3f along_cols = at(r, std::min(c + 1, cols_ - 1)) - at(r, std::max(c - 1, 0));
      const Eigen::Vector3f along_rows = at(std::min(r + 1, rows_ - 1), c) - at(std::max(r - 1, 0), c);
      const Eigen::Vector3f normal = along_cols.cross(along_rows);
      const float length = normal.norm();
      normals[static_cast<std::size_t>(r * cols_ + c)] = length > 0.0f ? Eigen::Vector3f(normal / length)
                                                                        : Eigen::Vector3f::UnitZ();
    }
  }
  fillMesh(positions, normals);
  context_->queueRender();
  return true;
}

void ClothStateDisplay::fillMesh(const std::vector<Eigen::Vector3f>& positions_m,
                                 const std::vector<Eigen::Vector3f>& normals) {
  const std::uint32_t count = static_cast<std::uint32_t>(positions_m.size());
  if (mesh_built_) {
    mesh_->beginUpdate(0);
  } else {
    mesh_->clear();
    mesh_->estimateVertexCount(2 * count);
    mesh_->estimateIndexCount(2 * indices_.size());
    mesh_->begin(material_->getName(), Ogre::RenderOperation::OT_TRIANGLE_LIST, resourceGroup());
  }
  for (int face = 0; face < 2; ++face) {
    const float sign = face == 0 ? 1.0f : -1.0f;
    for (std::uint32_t i = 0; i < count; ++i) {
      const Eigen::Vector3f& p = positions_m[i];
      const Eigen::Vector3f n = sign * normals[i];
      mesh_->position(p.x(), p.y(), p.z());
      mesh_->normal(n.x(), n.y(), n.z());
      mesh_->colour(colours_[i]);
    }
  }
  // The back face: the same triangles with two corners swapped, on the second copy of the vertices.
  for (std::uint32_t index : indices_) mesh_->index(index);
  for (std::size_t t = 0; t < indices_.size(); t += 3) {
    mesh_->index(count + indices_[t]);
    mesh_->index(count + indices_[t + 2]);
    mesh_->index(count + indices_[t + 1]);
  }
  mesh_->end();
  mesh_built_ = true;
}

}  // namespace cloth_sim

PLUGINLIB_EXPORT_CLASS(cloth_sim::ClothStateDisplay, rviz::Display)
