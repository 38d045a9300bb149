// The rviz display plugin is declared where rviz looks for it (package.xml's export, plugin_description.xml),
// its library resolves every symbol (an undefined one ended rviz itself at the first ClothState, so the
// library is opened with RTLD_NOW here), and pluginlib builds it as an rviz::Display with its properties.
// No display server: the class is created, not initialised. Run by test/ros/rviz_plugin.test, whose master
// ros::start() needs (a display holds a NodeHandle).
#include <pluginlib/class_loader.hpp>
#include <ros/ros.h>
#include <rviz/display.h>

#include <dlfcn.h>
#include <gtest/gtest.h>

#include <string>

namespace {
constexpr const char* kLookupName = "cloth_sim/ClothState";
}

TEST(RvizPlugin, TheClothStateDisplayIsDeclaredForRviz) {
  pluginlib::ClassLoader<rviz::Display> loader("rviz", "rviz::Display");
  ASSERT_TRUE(loader.isClassAvailable(kLookupName)) << "rviz does not see " << kLookupName
                                                    << " (package.xml export, plugin_description.xml)";
  EXPECT_EQ(loader.getClassType(kLookupName), "cloth_sim::ClothStateDisplay");
  EXPECT_EQ(loader.getClassPackage(kLookupName), "cloth_sim");
}

TEST(RvizPlugin, ItsLibraryResolvesEverySymbol) {
  pluginlib::ClassLoader<rviz::Display> loader("rviz", "rviz::Display");
  const std::string path = loader.getClassLibraryPath(kLookupName);
  void* library = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
  const char* error = library ? nullptr : dlerror();
  ASSERT_NE(library, nullptr) << path << ": " << (error ? error : "");
  dlclose(library);
}

TEST(RvizPlugin, PluginlibBuildsItWithItsProperties) {
  pluginlib::ClassLoader<rviz::Display> loader("rviz", "rviz::Display");
  // Not deleted: rviz's MessageFilterDisplay can only be destroyed after initialize(), which needs a
  // render context (rviz itself destroys only initialised displays). The test process ends right after.
  rviz::Display* display = loader.createUnmanagedInstance(kLookupName);
  ASSERT_NE(display, nullptr);
  for (const char* property : {"Topic", "Queue Size", "Checker", "Color", "Alpha"}) {
    EXPECT_NE(display->subProp(property), nullptr) << "no property '" << property << "'";
  }
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_rviz_plugin", ros::init_options::AnonymousName);
  return RUN_ALL_TESTS();
}
