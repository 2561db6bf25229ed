// The work-precision study's space knob on the flagellates (bench/common.hpp: refine_sections):
// refining every section k times, or merging runs of m identical sections into one, keeps the rod's
// rest shape (the helix's pieces share one rest strain) and changes only the number of sections.
#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include <stdexcept>
#include <string>

#include "common.hpp"
#include "scene.hpp"

using namespace cosserat;
using namespace cosserat::bench;

namespace {

const std::string kModels = COSSERAT_SOURCE_DIR "/models/";

Vec3 site_pos(const mj::Scene& s, const mj::SceneData& sd, const char* name) {
  const int i = mj_name2id(s.m, mjOBJ_SITE, name);
  EXPECT_GE(i, 0) << name;
  return i < 0 ? Vec3::Zero() : Vec3(sd.d->site_xpos[3 * i], sd.d->site_xpos[3 * i + 1], sd.d->site_xpos[3 * i + 2]);
}

int sections(const mj::Scene& s) { return static_cast<int>(s.rods.at(0).decl.proxies.size()); }

}  // namespace

// flagellate.xml: a hook (its own length and strain) and 12 helical sections; flagellate_rigid.xml:
// a hook and 8. Merged m to one they keep the hook and have 12/m (8/m) helical sections, and the
// tip and the hook's end stay where they were at rest (to rounding: the
// helix's end after 720 degrees, from fewer exponentials).
TEST(RefineSections, MergingIdenticalSectionsKeepsTheRestShape) {
  for (const auto& [file, helix] : {std::pair<std::string, int>{"flagellate.xml", 12}, {"flagellate_rigid.xml", 8}}) {
    const std::string path = kModels + file;
    const std::string xml = read_file(path);
    auto s0 = mj::load_scene_string(xml, path);
    mj::SceneData d0(*s0);
    mj::forward(*s0, d0);
    ASSERT_EQ(sections(*s0), 1 + helix) << file;
    for (int k : {-helix, -4, -2, 2}) {
      auto s = mj::load_scene_string(refine_sections(xml, k), path);
      mj::SceneData d(*s);
      mj::forward(*s, d);
      EXPECT_EQ(sections(*s), k < 0 ? 1 + helix / -k : k * (1 + helix)) << file << ", k = " << k;
      for (const char* site : {"hook_end", "flagellum/tip"})
        EXPECT_LT((site_pos(*s, d, site) - site_pos(*s0, d0, site)).norm(), 1e-12) << file << ", k = " << k << ", " << site;
    }
  }
}

// Merging needs whole runs: 12 helical sections do not merge 5 to one, nor does a lone section
// with its own length (the hook) merge with anything; `sections="6"` merges 3 to one into 2.
TEST(RefineSections, MergingRefusesRunsThatAreNotMultiples) {
  const std::string xml = read_file(kModels + "flagellate.xml");
  EXPECT_THROW(refine_sections(xml, -5), std::invalid_argument);
  EXPECT_THROW(refine_sections(xml, -24), std::invalid_argument);
  EXPECT_THROW(refine_sections(xml, -1), std::invalid_argument);
  EXPECT_THROW(refine_sections(xml, 0), std::invalid_argument);
  const std::string plain = R"(<mujoco><worldbody>
    <cosserat name="rod" length="1" sections="6" radius="0.01" young="1e6" density="1000"/>
  </worldbody></mujoco>)";
  auto s = mj::load_scene_string(refine_sections(plain, -3), "plain.xml");
  EXPECT_EQ(sections(*s), 2);
  EXPECT_THROW(refine_sections(plain, -4), std::invalid_argument);
}
