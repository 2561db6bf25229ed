// The `render` and `snapshot` commands (apps/render_commands.cpp, compiled into this test): frame
// numbering and count, identical frames from identical runs, picture sizes, video through ffmpeg,
// and one-line errors; all without a display.
#include "../../apps/render_commands.cpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

namespace {

namespace fs = std::filesystem;

const std::string kModels = std::string(COSSERAT_SOURCE_DIR) + "/models/";

int run(int (*command)(int, char**), std::vector<std::string> args) {
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  return command(static_cast<int>(args.size()), argv.data());
}

// Runs a command expecting failure; returns what it printed on stderr.
std::string failure(int (*command)(int, char**), std::vector<std::string> args) {
  testing::internal::CaptureStderr();
  const int status = run(command, std::move(args));
  const std::string err = testing::internal::GetCapturedStderr();
  EXPECT_EQ(status, 1) << err;
  EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << "one line: " << err;
  return err;
}

std::string bytes(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), {}};
}

std::vector<std::string> frames_in(const fs::path& dir) {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

class CommandsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    unsetenv("DISPLAY");  // no display: OSMesa only
    dir = fs::temp_directory_path() / ("cosserat_render_" + std::to_string(::getpid()) + "_" + std::string(testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(dir);
  }
  void TearDown() override { fs::remove_all(dir); }
  fs::path dir;
};

TEST_F(CommandsTest, RenderWritesDurationTimesFpsFramesNumberedWithoutGaps) {
  fs::create_directories(dir / "a");
  std::ofstream(dir / "a" / "frame_00042.png") << "stale";  // from an earlier, longer render
  std::ofstream(dir / "a" / "notes.txt") << "kept";
  ASSERT_EQ(run(render_command, {"render", kModels + "cantilever.xml", "--out", (dir / "a").string(), "--duration", "0.1",
                                 "--fps", "50", "--width", "160", "--height", "120"}),
            0);
  const std::vector<std::string> expected = {"frame_00000.png", "frame_00001.png", "frame_00002.png", "frame_00003.png",
                                             "frame_00004.png", "notes.txt"};
  EXPECT_EQ(frames_in(dir / "a"), expected);
  for (int k = 0; k < 5; ++k) {
    const cosserat::render::Image img = cosserat::render::read_png(cosserat::render::frame_path((dir / "a").string(), k));
    EXPECT_EQ(img.width, 160);
    EXPECT_EQ(img.height, 120);
  }
  // the simulation advances between frames: the beam starts to fall
  EXPECT_NE(bytes(dir / "a" / "frame_00000.png"), bytes(dir / "a" / "frame_00004.png"));

  // 0.25 s at 12 fps: frames at t = 0, 1/12, 2/12 (t = 3/12 is the end, not a frame)
  ASSERT_EQ(run(render_command, {"render", kModels + "cantilever.xml", "--out=" + (dir / "b").string(), "--duration=0.25",
                                 "--fps=12", "--width=64", "--height=48"}),
            0);
  EXPECT_EQ(frames_in(dir / "b"), (std::vector<std::string>{"frame_00000.png", "frame_00001.png", "frame_00002.png"}));
}

// render --mode K animates mode K at the static equilibrium: one cycle over the frames, the first
// and the half-cycle at the equilibrium, the quarter and three-quarter cycles on either side.
TEST_F(CommandsTest, RenderModeAnimatesOneCycleOfAMode) {
  testing::internal::CaptureStdout();
  ASSERT_EQ(run(render_command, {"render", kModels + "cantilever.xml", "--out", (dir / "m").string(), "--mode", "2",
                                 "--duration", "0.4", "--fps", "10", "--width", "160", "--height", "120", "--amplitude", "0.1"}),
            0);
  const std::string out = testing::internal::GetCapturedStdout();
  EXPECT_NE(out.find("mode 2 (2.28"), std::string::npos) << out;  // linearize's second frequency
  ASSERT_EQ(frames_in(dir / "m").size(), 4u);
  const std::string f0 = bytes(dir / "m" / "frame_00000.png"), f1 = bytes(dir / "m" / "frame_00001.png"),
                    f2 = bytes(dir / "m" / "frame_00002.png"), f3 = bytes(dir / "m" / "frame_00003.png");
  EXPECT_NE(f0, f1);
  EXPECT_NE(f1, f3);
  EXPECT_NE(f0, f3);
  EXPECT_EQ(f0, f2);  // sin(pi) A: 1e-17 m off the equilibrium
  EXPECT_NE(failure(render_command, {"render", kModels + "cantilever.xml", "--out", (dir / "n").string(), "--amplitude", "0.1"})
                .find("--amplitude"),
            std::string::npos);
  EXPECT_NE(failure(render_command, {"render", kModels + "cantilever.xml", "--out", (dir / "n").string(), "--mode", "1000"})
                .find("modes"),
            std::string::npos);
}

TEST_F(CommandsTest, TwoRunsOfTheSameCommandGiveIdenticalImages) {
  for (const char* run_dir : {"one", "two"})
    ASSERT_EQ(run(render_command, {"render", kModels + "octopus_arm.xml", "--out", (dir / run_dir).string(), "--duration",
                                   "0.06", "--fps", "50", "--width", "200", "--height", "150", "--key", "curl"}),
              0);
  const auto names = frames_in(dir / "one");
  ASSERT_EQ(names.size(), 3u);
  EXPECT_EQ(names, frames_in(dir / "two"));
  for (const auto& n : names) EXPECT_TRUE(bytes(dir / "one" / n) == bytes(dir / "two" / n)) << n;
}

TEST_F(CommandsTest, SnapshotHasTheRequestedSizeAtTheRequestedTime) {
  const fs::path out = dir / "sub" / "snap.png";
  ASSERT_EQ(run(snapshot_command, {"snapshot", kModels + "cantilever.xml", "--out", out.string(), "--time", "0.05",
                                   "--width", "300", "--height", "200", "--camera", "side"}),
            0);
  const cosserat::render::Image img = cosserat::render::read_png(out.string());
  EXPECT_EQ(img.width, 300);
  EXPECT_EQ(img.height, 200);
  // same picture as frame 5 of a 100 fps render with the same camera: t = 0.05 both
  ASSERT_EQ(run(render_command, {"render", kModels + "cantilever.xml", "--out", (dir / "r").string(), "--duration",
                                 "0.06", "--fps", "100", "--width", "300", "--height", "200", "--camera", "side"}),
            0);
  EXPECT_TRUE(bytes(out) == bytes(dir / "r" / "frame_00005.png"));
  // beyond the model's off-screen buffer (1280 x 720): not cropped
  ASSERT_EQ(run(snapshot_command, {"snapshot", kModels + "octopus_arm.xml", "--out", (dir / "big.png").string(), "--width",
                                   "1500", "--height", "900", "--color-by", "strain", "--no-shadows"}),
            0);
  const cosserat::render::Image big = cosserat::render::read_png((dir / "big.png").string());
  EXPECT_EQ(big.width, 1500);
  EXPECT_EQ(big.height, 900);
  long right = 0;  // the top-right corner beyond 1280 x 720 is drawn, not left black
  for (int y = 0; y < 100; ++y)
    for (int x = 1400; x < 1500; ++x) right += big.pixel(x, y)[0] + big.pixel(x, y)[1] + big.pixel(x, y)[2];
  EXPECT_GT(right, 100L * 100 * 300);
}

// Every container of the README's list that needs its own encoder (outside probe U: .webm and .gif
// were given H.264, which neither takes: ffmpeg failed after every frame and left a broken file).
TEST_F(CommandsTest, VideoIsEncodedWithFfmpeg) {
  if (cosserat::render::find_program("ffmpeg").empty()) GTEST_SKIP() << "ffmpeg is not installed";
  for (const char* ext : {".mp4", ".webm", ".gif"}) {
    SCOPED_TRACE(ext);
    const fs::path video = dir / "v" / (std::string("cantilever") + ext);
    ASSERT_EQ(run(render_command, {"render", kModels + "cantilever.xml", "--out", (dir / "frames").string(), "--duration",
                                   "0.2", "--fps", "25", "--width", "161", "--height", "121", "--video", video.string()}),
              0);
    ASSERT_TRUE(fs::exists(video));
    EXPECT_GT(fs::file_size(video), 1000u);
    if (cosserat::render::find_program("ffprobe").empty()) continue;
    const std::string probe = "ffprobe -v error -count_frames -select_streams v:0 -show_entries stream=nb_read_frames "
                              "-of csv=p=0 '" + video.string() + "' > '" + (dir / "n.txt").string() + "'";
    ASSERT_EQ(std::system(probe.c_str()), 0);
    EXPECT_EQ(std::stoi(bytes(dir / "n.txt")), 5);
  }
}

// render --mode K --video plays the cycle at --fps, in --duration (outside probe BF: always at 30
// fps, a 2 s cycle of 20 frames in 0.67 s).
TEST_F(CommandsTest, ModeVideoPlaysAtTheFps) {
  if (cosserat::render::find_program("ffprobe").empty()) GTEST_SKIP() << "ffprobe is not installed";
  const fs::path video = dir / "mode.mp4";
  testing::internal::CaptureStdout();
  ASSERT_EQ(run(render_command, {"render", kModels + "cantilever.xml", "--out", (dir / "m").string(), "--mode", "1",
                                 "--duration", "2", "--fps", "10", "--width", "160", "--height", "120", "--video",
                                 video.string()}),
            0);
  testing::internal::GetCapturedStdout();
  const std::string probe = "ffprobe -v error -select_streams v:0 -show_entries stream=r_frame_rate,nb_frames -of "
                            "csv=p=0 '" + video.string() + "' > '" + (dir / "p.txt").string() + "'";
  ASSERT_EQ(std::system(probe.c_str()), 0);
  EXPECT_EQ(bytes(dir / "p.txt"), "10/1,20\n");
}

// Frame k shows the step nearest to k/fps: where a step is a sizeable part of 1/fps the frames are
// unevenly spaced, and render says so (outside probe BF: 30 fps at 0.02 s steps showed t = 0, 0.04,
// 0.06, 0.10, ... without a word); 1 ms steps at 30 fps (33 or 34 steps a frame) are not worth a word.
TEST_F(CommandsTest, UnevenlySpacedFramesAreWarnedAbout) {
  auto warnings = [&](const std::string& fps, const std::string& timestep) {
    testing::internal::CaptureStderr();
    testing::internal::CaptureStdout();
    EXPECT_EQ(run(render_command, {"render", kModels + "cantilever.xml", "--out", (dir / "f").string(), "--duration",
                                   "0.2", "--fps", fps, "--timestep", timestep, "--width", "32", "--height", "24"}),
              0);
    testing::internal::GetCapturedStdout();
    return testing::internal::GetCapturedStderr();
  };
  const std::string uneven = warnings("30", "0.02");
  EXPECT_NE(uneven.find("warning: --fps 30 puts frames 0.0333333 s apart, 1.66667 time steps of 0.02 s: each frame "
                        "shows the step nearest its time k/fps, so frames are 0.02 to 0.04 s apart (up to 40% off)"),
            std::string::npos)
      << uneven;
  EXPECT_EQ(warnings("25", "0.02").find("warning:"), std::string::npos);   // 2 steps a frame
  EXPECT_EQ(warnings("30", "0.001").find("warning:"), std::string::npos);  // 33 or 34 steps: 2% off
  EXPECT_NE(warnings("30", "0.005").find("warning: --fps 30"), std::string::npos);  // 6 or 7 steps: 10% off
}

// A rod falling far stays in render's pictures: the free camera framing 44 m of fall stands beyond
// MuJoCo's far plane (50 x the model's extent, from its initial pose), which had left the last
// frames blank (outside probe BF).
TEST_F(CommandsTest, AFallingRodStaysInTheFrames) {
  const fs::path model = dir / "fall.xml";
  fs::create_directories(dir);
  std::ofstream(model) << R"(<mujoco><option timestep="0.002"/>
  <worldbody><light pos="0 -1 3" dir="0 0.3 -1" directional="true"/>
    <body name="hub" pos="0 0 1"><freejoint/>
      <geom type="sphere" size="0.1" mass="0.05" rgba="0 0 1 1" contype="0" conaffinity="0"/>
      <cosserat name="rod" pos="0.1 0 0" length="0.6" sections="2" radius="0.06" young="1e7" rgba="1 0 0 1"
                contype="0" conaffinity="0"/>
    </body></worldbody></mujoco>)";
  testing::internal::CaptureStdout();
  ASSERT_EQ(run(render_command, {"render", model.string(), "--out", (dir / "f").string(), "--duration", "3", "--fps", "2",
                                 "--width", "320", "--height", "240", "--no-shadows"}),
            0);
  testing::internal::GetCapturedStdout();
  const auto names = frames_in(dir / "f");
  ASSERT_EQ(names.size(), 6u);
  for (const auto& n : names) {
    const rd::Image img = rd::read_png((dir / "f" / n).string());
    int drawn = 0;
    for (int y = 0; y < img.height; ++y)
      for (int x = 0; x < img.width; ++x) drawn += img.pixel(x, y)[0] != img.pixel(0, 0)[0] || img.pixel(x, y)[2] != img.pixel(0, 0)[2];
    EXPECT_GE(drawn, 8) << n;
  }
}

TEST_F(CommandsTest, VideoWithoutFfmpegSaysSo) {
  const std::string path = std::getenv("PATH") ? std::getenv("PATH") : "";
  setenv("PATH", "/nonexistent", 1);
  const std::string err = failure(render_command, {"render", kModels + "cantilever.xml", "--out", dir.string(), "--video",
                                                   (dir / "x.mp4").string(), "--duration", "0.1"});
  setenv("PATH", path.c_str(), 1);
  EXPECT_NE(err.find("ffmpeg"), std::string::npos) << err;
  EXPECT_NE(err.find("not installed"), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(dir)) << "nothing rendered";
}

TEST_F(CommandsTest, BadInputIsAOneLineError) {
  const std::string model = kModels + "cantilever.xml";
  EXPECT_NE(failure(render_command, {"render", model}).find("--out"), std::string::npos);
  EXPECT_NE(failure(snapshot_command, {"snapshot", model, "--out", (dir / "s.png").string(), "--camera", "top"}).find("side"),
            std::string::npos);
  EXPECT_NE(failure(render_command, {"render", model, "--out", dir.string(), "--fps", "0"}).find("--fps"), std::string::npos);
  // frames closer than a time step (1 ms here): refused before any frame is written, naming --fps
  // (3000 fps had written frame 0 and then failed about "the simulated time": an outside probe)
  const std::string fast = failure(render_command, {"render", model, "--out", (dir / "fast").string(), "--duration",
                                                    "0.01", "--fps", "3000", "--width", "32", "--height", "24"});
  EXPECT_NE(fast.find("--fps 3000"), std::string::npos) << fast;
  EXPECT_NE(fast.find("--fps 1000 or less"), std::string::npos) << fast;
  EXPECT_FALSE(fs::exists(dir / "fast" / "frame_00000.png"));
  EXPECT_NE(failure(render_command, {"render", model, "--out", dir.string(), "--frobnicate"}).find("--frobnicate"),
            std::string::npos);
  EXPECT_NE(failure(snapshot_command, {"snapshot", model, "--out", (dir / "s.png").string(), "--color-by", "heat"}).find("heat"),
            std::string::npos);
  EXPECT_NE(failure(snapshot_command, {"snapshot", model, "--out", (dir / "s.png").string(), "--track", "nobody"}).find("nobody"),
            std::string::npos);
  EXPECT_NE(failure(snapshot_command, {"snapshot", kModels + "missing.xml", "--out", (dir / "s.png").string()}).find("missing.xml"),
            std::string::npos);
  // an unwritable picture is refused before the simulation, naming --out (it had simulated to
  // --time first)
  EXPECT_NE(failure(snapshot_command, {"snapshot", model, "--out", "/proc/no_such_dir/s.png", "--time", "1e6"})
                .find("--out: cannot write /proc/no_such_dir/s.png"),
            std::string::npos);
  // a model error names file and line
  fs::create_directories(dir);
  std::ofstream(dir / "bad.xml") << "<mujoco>\n<worldbody>\n<cosserat name=\"r\" length=\"-1\"/>\n</worldbody>\n</mujoco>\n";
  EXPECT_NE(failure(snapshot_command, {"snapshot", (dir / "bad.xml").string(), "--out", (dir / "s.png").string()})
                .find("bad.xml:3:"),
            std::string::npos);
  // options that would do nothing are refused, and render's --out is checked before the model
  // (outside probe BB: the free camera's options with --camera, --color-max without --color-by,
  // --samples beyond OpenGL's, a .jpg name for PNG data, all accepted; a bad model reported first)
  const std::string png = (dir / "s.png").string();
  EXPECT_NE(failure(snapshot_command, {"snapshot", model, "--out", png, "--camera", "side", "--azimuth", "30"})
                .find("--azimuth, --elevation and --margin place the free camera: drop --camera side"),
            std::string::npos);
  EXPECT_NE(failure(snapshot_command, {"snapshot", model, "--out", png, "--color-max", "0.1"})
                .find("--color-max is the top of the strain or stress colour map"),
            std::string::npos);
  EXPECT_NE(failure(snapshot_command, {"snapshot", model, "--out", png, "--samples", "1000"})
                .find("--samples 1000: OpenGL here multisamples at most"),
            std::string::npos);
  EXPECT_NE(failure(snapshot_command, {"snapshot", model, "--out", (dir / "s.jpg").string()})
                .find("--out: the picture is a PNG: give a name ending in .png"),
            std::string::npos);
  EXPECT_NE(failure(render_command, {"render", (dir / "bad.xml").string(), "--out", "/proc/no_such_dir"})
                .find("--out: cannot create directory /proc/no_such_dir"),
            std::string::npos);
}

TEST_F(CommandsTest, HelpListsTheOptions) {
  testing::internal::CaptureStdout();
  EXPECT_EQ(run(render_command, {"render", "--help"}), 0);
  const std::string help = testing::internal::GetCapturedStdout();
  for (const char* o : {"--out", "--duration", "--fps", "--width", "--height", "--camera", "--video", "--track", "--color-by",
                        "--newton", "--newton-tol", "--newton-memory", "--newton-refresh", "--rho"})
    EXPECT_NE(help.find(o), std::string::npos) << o;
  testing::internal::CaptureStdout();
  EXPECT_EQ(run(snapshot_command, {"snapshot", "--help"}), 0);
  EXPECT_NE(testing::internal::GetCapturedStdout().find("--time"), std::string::npos);
}

}  // namespace

namespace {

// A rod section that collapsed is reported by the picture commands too: a warning on stderr after a
// snapshot of the soft string of docs/bench/repro/ (it inverts a section at 1.8 s), and in the
// one-line reason of a render that diverges after the collapse.
TEST_F(CommandsTest, CollapsedSectionIsReported) {
  const std::string soft = std::string(COSSERAT_SOURCE_DIR) + "/docs/bench/repro/soft_string_collapse.xml";
  testing::internal::CaptureStderr();
  ASSERT_EQ(run(snapshot_command, {"snapshot", soft, "--out", (dir / "s.png").string(), "--time", "2", "--integrator",
                                   "midpoint", "--width", "64", "--height", "48"}),
            0);
  const std::string warn = testing::internal::GetCapturedStderr();
  EXPECT_NE(warn.find("warning: section 1 of rod 'rod' was compressed to"), std::string::npos) << warn;
  const std::string err = failure(render_command, {"render", soft, "--out", (dir / "r").string(), "--duration", "2",
                                                   "--fps", "5", "--integrator", "implicit", "--width", "64",
                                                   "--height", "48"});
  EXPECT_NE(err.find("after a rod section collapsed: section 3 of rod 'rod'"), std::string::npos) << err;
  // no warning without a collapse
  testing::internal::CaptureStderr();
  ASSERT_EQ(run(snapshot_command, {"snapshot", kModels + "cantilever.xml", "--out", (dir / "c.png").string(), "--time",
                                   "0.05", "--width", "64", "--height", "48"}),
            0);
  EXPECT_EQ(testing::internal::GetCapturedStderr().find("warning:"), std::string::npos);
}

// render's free camera frames the whole run, not its first state: a soft red rod released straight
// and horizontal swings down far below where it started, and every frame shows all of it and its
// green tip ball inside the picture (none of their pixels on the border). Framed on the first
// state, the ball had left the picture in half the frames (an outside probe).
TEST_F(CommandsTest, RenderFramesTheWholeRun) {
  const fs::path model = dir / "swing.xml";
  fs::create_directories(dir);
  std::ofstream(model) << R"(<mujoco><option timestep="0.001" gravity="0 0 -9.81"/>
  <visual><quality offsamples="0"/></visual>
  <worldbody><light pos="0 -1 2" dir="0 0.5 -1" directional="true"/>
    <cosserat name="beam" pos="0 0 1" length="0.5" sections="8" strain="kl" radius="0.01" density="1000"
              young="1e6" poisson="0.5" viscosity="0.5" rgba="1 0 0 1">
      <body name="tipball" pos="0.02 0 0"><geom type="sphere" size="0.02" mass="0.01" rgba="0 1 0 1"/></body>
    </cosserat></worldbody></mujoco>)";
  ASSERT_EQ(run(render_command, {"render", model.string(), "--out", (dir / "f").string(), "--duration", "1", "--fps",
                                 "10", "--width", "160", "--height", "120", "--no-shadows"}),
            0);
  const auto names = frames_in(dir / "f");
  ASSERT_EQ(names.size(), 10u);
  for (const auto& n : names) {
    SCOPED_TRACE(n);
    const rd::Image img = rd::read_png((dir / "f" / n).string());
    int ball = 0, on_border = 0;
    for (int y = 0; y < img.height; ++y)
      for (int x = 0; x < img.width; ++x) {
        const std::uint8_t* c = img.pixel(x, y);
        const bool red = c[0] > 90 && c[1] < 60 && c[2] < 60, green = c[1] > 90 && c[0] < 60 && c[2] < 60;
        ball += green;
        if ((red || green) && (x < 2 || y < 2 || x >= img.width - 2 || y >= img.height - 2)) ++on_border;
      }
    EXPECT_GT(ball, 4);
    EXPECT_EQ(on_border, 0);
  }
}

// --step-tol reaches the pictures' simulation: the whipping heavy tip at 1.5 s under adaptive
// substeps is not the picture of its fixed 5 ms steps (whose energy wanders), and rk4 refuses it.
TEST_F(CommandsTest, SnapshotTakesAdaptiveSubsteps) {
  const std::string tip = std::string(COSSERAT_SOURCE_DIR) + "/docs/bench/repro/heavy_tip.xml";
  auto snap = [&](const std::string& name, std::vector<std::string> extra) {
    std::vector<std::string> args = {"snapshot", tip, "--out", (dir / name).string(), "--time", "1.5",
                                     "--integrator", "trapezoidal", "--width", "64", "--height", "48"};
    args.insert(args.end(), extra.begin(), extra.end());
    EXPECT_EQ(run(snapshot_command, args), 0);
    return bytes(dir / name);
  };
  EXPECT_NE(snap("fixed.png", {}), snap("adaptive.png", {"--step-tol", "1e-2"}));
  const std::string err = failure(snapshot_command, {"snapshot", tip, "--out", (dir / "rk4.png").string(), "--time",
                                                     "0.01", "--integrator", "rk4", "--step-tol", "1e-2"});
  EXPECT_NE(err.find("--step-tol: adaptive substeps are for implicit"), std::string::npos) << err;
  // and run's Newton and genalpha options (they were missing: a run could not be pictured with the
  // settings it ran with; an outside probe)
  const std::string newton10 = snap("newton10.png", {}), newton2 = snap("newton2.png", {"--newton", "2"});
  EXPECT_NE(newton10, newton2);
  EXPECT_EQ(newton10, snap("newton10_again.png", {"--newton", "10", "--newton-tol", "1e-6", "--newton-memory", "3"}));
  const std::string rho0 = snap("rho0.png", {"--integrator", "genalpha", "--rho", "0"});
  EXPECT_NE(rho0, snap("rho1.png", {"--integrator", "genalpha", "--rho", "1"}));
  const std::string bad = failure(snapshot_command, {"snapshot", tip, "--out", (dir / "bad.png").string(), "--rho", "2"});
  EXPECT_NE(bad.find("--rho: 2 is not in [0, 1]"), std::string::npos) << bad;
}

}  // namespace
