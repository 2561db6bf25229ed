#include "render_commands.hpp"

#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <climits>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "adaptive_option.hpp"
#include "newton_options.hpp"
#include "state_options.hpp"
#include "cli.hpp"
#include "progress.hpp"
#include "integrators.hpp"
#include "png_io.hpp"
#include "renderer.hpp"
#include "scene.hpp"
#include "scene_statics.hpp"
#include "video.hpp"

namespace {

using namespace cosserat::cli;
namespace fs = std::filesystem;
namespace mj = cosserat::mj;
namespace rd = cosserat::render;
using cosserat::Integrator;

// A number option; `positive`: > 0 required (else >= lo).
Option number(const std::string& name, const std::string& metavar, const std::string& help, double& target,
              double lo = -HUGE_VAL, double hi = HUGE_VAL, bool positive = false) {
  return {name, metavar, help, [&target, name, lo, hi, positive](const std::string& v) {
            target = parse_number(name, v);
            if (positive && !(target > 0)) fail(name + ": must be positive, got '" + v + "'");
            if (target < lo || target > hi)
              fail(name + (hi == HUGE_VAL ? ": must be at least " + format_g(lo)
                                          : ": must be in [" + format_g(lo) + ", " + format_g(hi) + "]") +
                   ", got '" + v + "'");
          }};
}
// ------------------------------------------------------------------- options both commands share --

struct PictureOptions {
  std::string out;
  rd::RenderOptions render;
  std::string coloring = "model";
  StateOptions state;    // --key, --ctrl
  double timestep = 0;  // 0: the model's
  std::string integrator;
  std::optional<double> step_tol;  // mj::Scene::step_tol (none: the model's)
  NewtonOptions newton;            // --newton*, --rho

  void add_to(CommandLine& c) {
    rd::RenderOptions& r = render;
    c.options.push_back(int_option("--width", "W", "picture width in pixels (default: the model's offwidth)", r.width, 1));
    c.options.push_back(int_option("--height", "H", "picture height in pixels (default: the model's offheight)", r.height, 1));
    c.options.push_back(text_option("--camera", "NAME", "a camera of the model (default: a free camera framing the scene: render's the whole run, snapshot's the picture's state)", r.camera.name));
    c.options.push_back(text_option("--track", "BODY", "the free camera follows this body (framed on the first picture's state)", r.camera.track));
    c.options.push_back(given(number("--azimuth", "DEG", "free camera azimuth (default 90: looking along +y)", r.camera.azimuth), free_camera_given));
    c.options.push_back(given(number("--elevation", "DEG", "free camera elevation (default -20: from above)", r.camera.elevation, -89, 89), free_camera_given));
    c.options.push_back(given(number("--margin", "F", "free camera: empty border, fraction of the picture (default 0.08)", r.camera.margin, 0, 0.45), free_camera_given));
    c.options.push_back(text_option("--color-by", "WHAT", "rod colours: model (the MJCF rgba), strain or stress (magnitude at the surface)", coloring));
    c.options.push_back(given(positive_option("--color-max", "V", "with --color-by strain or stress: the value at the top of the colour map (default: the largest in each picture)",
                                 r.rods.color_max), color_max_given));
    c.options.push_back(int_option("--rod-segments", "N", "rings drawn along each rod's tube, evenly spaced (default: adaptive to its bending)", r.rods.segments, 1));
    c.options.push_back({"--no-shadows", "", "do not draw shadows", [&r](const std::string&) { r.shadows = false; }});
    c.options.push_back(int_option("--samples", "N", "multisampling per pixel (default: the model's offsamples)", r.samples, 0));
    state.add_to(c, true);
    c.options.push_back(positive_option("--timestep", "h", "time step [s] (default: the model's <option timestep>)", timestep));
    c.options.push_back(text_option("--integrator", "NAME", "euler | implicit | trapezoidal | genalpha | midpoint | rk4 | rosenbrock (default: implicit with rods, euler without; see 'cosserat run --help')", integrator));
    c.options.push_back(optional_positive_option("--step-tol", "TOL", "adaptive substeps to this tolerance (implicit, trapezoidal, genalpha, midpoint; default: the model's cosserat:step_tol, else fixed steps; see 'cosserat run --help')", step_tol));
    newton.add_newton_to(c);
    newton.add_rho_to(c);
  }

  // (outside probe BB: these were accepted and did nothing)
  bool free_camera_given = false, color_max_given = false;
  // `o` that also sets `flag` when given
  static Option given(Option o, bool& flag) {
    o.set = [set = std::move(o.set), &flag](const std::string& v) {
      set(v);
      flag = true;
    };
    return o;
  }

  void finish() {
    if (out.empty()) fail("--out is required");
    if (free_camera_given && !render.camera.name.empty())
      fail("--azimuth, --elevation and --margin place the free camera: drop --camera " + render.camera.name + " to use them");
    if (color_max_given && coloring == "model")
      fail("--color-max is the top of the strain or stress colour map: give --color-by strain or --color-by stress");
    if (render.rods.segments > 10000) fail("--rod-segments: at most 10000 rings per rod, got " + std::to_string(render.rods.segments));
    render.rods.coloring = rd::parse_rod_coloring(coloring);
  }
};

// A loaded scene at its initial state, stepping with the chosen time step and integrator.
struct Simulation {
  std::unique_ptr<mj::Scene> scene;
  std::unique_ptr<mj::SceneData> data;
  Integrator integrator = Integrator::Implicit;
  double t0 = 0;
  long steps = 0;

  Simulation(const std::string& path, const PictureOptions& o) : scene(mj::load_scene(path)) {
    for (const auto& w : scene->load_warnings) std::fprintf(stderr, "warning: %s\n", w.c_str());
    mjModel* m = scene->m;
    if (o.timestep > 0) m->opt.timestep = o.timestep;
    integrator = scene->integrator;
    if (!o.integrator.empty()) {
      const auto in = cosserat::integrator_from_name(o.integrator);
      if (!in) fail("--integrator: unknown integrator '" + o.integrator + "' (" + cosserat::kIntegratorNames + ")");
      integrator = *in;
    }
    o.newton.apply(*scene, integrator);
    apply_step_tol(*scene, integrator, o.step_tol);
    restart(o);
  }

  // Back to the initial state (the same scene: a Renderer made for it stays valid).
  void restart(const PictureOptions& o) {
    data = std::make_unique<mj::SceneData>(*scene);
    o.state.apply(*scene, *data);
    t0 = data->d->time;
    steps = 0;
  }

  // Steps until `t` after the start (to the nearest step) and brings the kinematics up to date.
  // With `progress_label`, the steps shown as a command's progress (snapshot's simulation up to its
  // picture, which outside probe CL found silent for 18 s at --time 500).
  void advance_to(double t, const char* progress_label = nullptr) {
    const long target = step_count(t, scene->m->opt.timestep, "the simulated time (--time, --duration)");
    std::optional<Progress> progress;
    if (progress_label) progress.emplace(progress_label, target - steps, "step");
    for (const long first = steps; steps < target; ++steps) {
      if (mj::step(*scene, *data, integrator) != cosserat::Status::Ok) {
        const std::string c = mj::collapse_warning(*scene, *data);
        fail("the simulation diverged: " + data->warning + (c.empty() ? "" : " (after a rod section collapsed: " + c + ")"));
      }
      if (progress) progress->update(steps + 1 - first, time());
    }
    mj::fwd_position(*scene, *data);
  }
  // The collapse warning on stderr, if a rod section collapsed (mj::collapse_warning), and the
  // fluid's warnings.
  void warn() const {
    if (const std::string c = mj::collapse_warning(*scene, *data); !c.empty()) std::fprintf(stderr, "warning: %s\n", c.c_str());
    for (const auto& w : scene->fluid.warnings) std::fprintf(stderr, "warning: fluid: %s\n", w.c_str());
  }
  double time() const { return data->d->time - t0; }
};


// The renderer's warnings on stderr (what the pictures do not show as the model asks).
void warn_renderer(const rd::Renderer& r) {
  for (const auto& w : r.warnings()) std::fprintf(stderr, "warning: %s\n", w.c_str());
}

// Frame k of `render` shows the step nearest to k/fps (Simulation::advance_to). Where 1/fps is not
// a whole number of steps the frames are one step unevenly spaced; a warning when one step is
// more than 5% of 1/fps (outside probe BF: 30 fps at h = 0.02 s showed t = 0, 0.04, 0.06, 0.10, ...
// without a word), which 1 ms steps at up to 50 fps are not.
std::string uneven_frames_warning(double fps, double h, long frames) {
  const double per_frame = 1.0 / (fps * h);  // steps per frame interval
  if (frames < 2 || std::abs(per_frame - std::round(per_frame)) <= 1e-9 * per_frame) return "";
  long lo = LONG_MAX, hi = 0, prev = 0;
  for (long k = 1; k < std::min(frames, 100000L); ++k) {
    const long n = std::lround(k * per_frame);
    lo = std::min(lo, n - prev), hi = std::max(hi, n - prev);
    prev = n;
  }
  const double worst = std::max(hi - per_frame, per_frame - lo) / per_frame;
  if (worst <= 0.05) return "";
  return "--fps " + format_g(fps) + " puts frames " + format_g(1.0 / fps) + " s apart, " + format_g(per_frame) +
         " time steps of " + format_g(h) + " s: each frame shows the step nearest its time k/fps, so frames are " +
         (lo == hi ? format_g(lo * h) : format_g(lo * h) + " to " + format_g(hi * h)) + " s apart (up to " +
         format_g(std::round(100 * worst)) + "% off) and motion plays unevenly; an --fps of " + format_g(1.0 / h) +
         " divided by a whole number, or a --timestep dividing " + format_g(1.0 / fps) + " s, spaces them evenly";
}

// Runs a command body and turns every failure into a one-line message and status 1.
int guarded(const std::function<int()>& body) {
  auto one_line = [](std::string s) {
    std::replace(s.begin(), s.end(), '\n', ' ');
    return s;
  };
  try {
    return body();
  } catch (const mj::LoadError& e) {
    std::cerr << one_line(e.what()) << "\n";
  } catch (const std::exception& e) {
    std::cerr << "cosserat: " << one_line(e.what()) << "\n";
  }
  return 1;
}

// `render --mode K`: the frames of one cycle of mode K at the static equilibrium of the scene's
// initial state (the physics, equilibrium, linearisation and mode shape, is the coupling's; the
// frames only pose the scene along the mode and draw it).
int render_mode(Simulation& sim, const PictureOptions& o, int mode, double amplitude, long frames, double fps,
                const std::string& video) {
  const mj::Scene& s = *sim.scene;
  mj::SceneData& sd = *sim.data;
  const mjModel* m = s.m;
  const mj::SceneStaticsResult eq = mj::equilibrium(s, sd);
  if (!eq.converged) fail("--mode: no static equilibrium to linearise about: " + eq.message);
  const mj::SceneLinearization lin = mj::linearize(s, sd);
  if (mode > lin.omega2.size())
    fail("--mode " + std::to_string(mode) + ": the linearisation has " + std::to_string(lin.omega2.size()) + " modes");
  const mj::ModeShape shape = mj::mode_shape(s, sd, lin, mode - 1);
  if (amplitude == 0.0) {
    amplitude = 0.05;
    for (const auto& r : s.rods) amplitude = std::max(amplitude, 0.1 * r.model.rods.front().length);
  }
  const std::vector<mjtNum> q0(sd.d->qpos, sd.d->qpos + m->nq);
  auto pose = [&](double phase) {
    std::copy(q0.begin(), q0.end(), sd.d->qpos);
    mj_integratePos(m, sd.d->qpos, shape.dq.data(), amplitude * std::sin(phase));
    mju_zero(sd.d->qvel, m->nv);
    mj::fwd_position(s, sd);
  };
  rd::Renderer renderer(s, o.render);  // (--out's directory: render_command made it)
  warn_renderer(renderer);
  if (renderer.free_camera() && o.render.camera.track.empty()) {  // framed on the cycle's extremes
    rd::Extent e;
    for (const double phase : {0.0, M_PI / 2, -M_PI / 2}) {
      pose(phase);
      e.add(rd::scene_extent(s, sd, renderer.option()));
    }
    renderer.frame(e);
  }
  rd::remove_frames(o.out);
  Progress progress("render", frames, "frame");
  for (long k = 0; k < frames; ++k) {
    pose(2 * M_PI * static_cast<double>(k) / static_cast<double>(frames));
    rd::write_png(rd::frame_path(o.out, static_cast<int>(k)), renderer.render(sd));
    progress.update(k + 1, 0.0);
  }
  progress.clear();
  if (!video.empty()) rd::encode_video(o.out, fps, video);  // the cycle plays in --duration (outside probe BF: at 30 fps)
  std::printf("render: mode %d (%s) at the equilibrium, amplitude %g %s: %ld frames %dx%d in %s%s\n", mode,
              shape.omega2 < 0 ? ("unstable, omega^2 = " + format_g(shape.omega2) + " 1/s^2").c_str()
                               : (format_g(shape.frequency_hz) + " Hz").c_str(),
              amplitude, shape.displaces ? "m" : "in its largest coordinate (it moves no rod centreline, site or body)",
              frames, renderer.width(), renderer.height(), o.out.c_str(), video.empty() ? "" : (", video " + video).c_str());
  return 0;
}

}  // namespace

int render_command(int argc, char** argv) {
  return guarded([&] {
    PictureOptions o;
    double duration = 1.0, fps = 30.0, amplitude = 0.0;
    int mode = 0;
    std::string video;
    CommandLine cl{"render",
                   "simulate and write frames DIR/frame_00000.png ... at t = k/fps (the nearest time step), k = 0 .. duration*fps - 1",
                   {"MODEL.xml"},
                   {},
                   "Frames left in DIR by an earlier render are removed first. Rendering is headless (OSMesa):\n"
                   "no display is needed. A progress bar is shown when stderr is a terminal.\n"
                   "Frame k shows the state at the time step nearest to k/fps: where 1/fps is not a whole number\n"
                   "of steps the frames are unevenly spaced by one step (a warning says so when a step is more than\n"
                   "5% of 1/fps); --video plays them at --fps.\n"
                   "With --mode K the frames animate mode K of the linearisation at the static equilibrium\n"
                   "(`cosserat linearize`) instead: one cycle, q = q_eq + A sin(2 pi k / frames) x_K, over the\n"
                   "duration * fps frames, a --video cycle lasting --duration (the time step and integrator serve\n"
                   "the equilibrium's relaxation).\n",
                   "MODEL.xml --out DIR [options]"};
    cl.options.push_back(text_option("--out", "DIR", "directory of the frames (created)", o.out));
    cl.options.push_back(positive_option("--duration", "T", "simulated time [s] (default 1)", duration));
    cl.options.push_back(positive_option("--fps", "F", "frames per simulated second, and the video's frame rate (default 30)", fps));
    cl.options.push_back(int_option("--mode", "K", "animate mode K (1: the lowest) at the static equilibrium instead of simulating", mode, 1));
    cl.options.push_back(positive_option("--amplitude", "A", "--mode: the largest displacement [m] (default: the larger of 0.05 and a tenth of the longest rod)", amplitude));
    cl.options.push_back(text_option("--video", "F.mp4", "also encode the frames into a video with ffmpeg (must be installed)", video));
    o.add_to(cl);
    const auto pos = cl.parse(argc - 1, argv + 1);  // after the command name
    if (!pos) return 0;
    o.finish();
    const double nframes = duration * fps;
    if (!(nframes < 1e7)) fail("--duration " + format_g(duration) + " at --fps " + format_g(fps) + " makes more than 1e7 frames");
    const long frames = std::lround(nframes);
    if (frames < 1) fail("--duration " + format_g(duration) + " at --fps " + format_g(fps) + " makes no frame");
    if (!video.empty() && rd::find_program("ffmpeg").empty())
      fail("--video needs ffmpeg, which is not installed (apt-get install ffmpeg); without --video only the frames are written");
    if (!video.empty()) {  // ffmpeg picks the container from the extension: a wrong one failed after every frame
      std::string ext = std::filesystem::path(video).extension().string();
      std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
      if (ext != ".mp4" && ext != ".mkv" && ext != ".webm" && ext != ".mov" && ext != ".avi" && ext != ".gif" && ext != ".m4v")
        fail("--video: " + video + ": ffmpeg takes the video's format from its extension; use .mp4, .mkv, .webm, .mov, "
             ".avi, .m4v or .gif");
      try {
        rd::check_video_encoder(video);
      } catch (const std::exception& e) {
        fail(std::string("--video: ") + e.what());
      }
    }
    check_writable("--video", video);

    if (amplitude > 0 && mode == 0) fail("--amplitude is the amplitude of --mode K's animation: give --mode too");
    if (mode > 0 && !o.state.ctrl_file.empty())
      fail("--ctrl-file: --mode animates a mode about the equilibrium of constant controls: give --key or --ctrl");
    // the frames' directory before the model is loaded (outside probe BB: a bad model was reported
    // before a bad --out, unlike the other commands)
    std::error_code ec;
    create_output_directories(o.out, ec);
    if (!fs::is_directory(o.out)) fail("--out: cannot create directory " + o.out + (ec ? " (" + ec.message() + ")" : ""));
    check_writable("--out", rd::frame_path(o.out, 0));
    Simulation sim((*pos)[0], o);
    if (mode > 0) return render_mode(sim, o, mode, amplitude, frames, fps, video);
    const double h = sim.scene->m->opt.timestep;
    step_count((frames - 1) / fps, h, "--duration");  // before any frame is written
    if (frames > 1 && fps * h > 1.0 + 1e-9)  // frames closer than a step: repeated pictures, or none at all
      fail("--fps " + format_g(fps) + " puts frames " + format_g(1.0 / fps) + " s apart, closer than the time step " +
           format_g(h) + " s: use --fps " + format_g(1.0 / h) + " or less, or a smaller --timestep");
    if (const std::string w = uneven_frames_warning(fps, h, frames); !w.empty()) std::fprintf(stderr, "warning: %s\n", w.c_str());
    rd::Renderer renderer(*sim.scene, o.render);
    warn_renderer(renderer);
    if (renderer.free_camera() && o.render.camera.track.empty()) {
      // the free camera frames the whole run: a first pass simulates it (up to a divergence, which
      // the second pass then reports after writing the frames before it) and merges the extents
      // of at most 2000 frames evenly spread
      Progress progress("frame the motion", frames, "frame");
      const long every = std::max(1L, (frames + 1999) / 2000);
      rd::Extent e;
      try {
        for (long k = 0; k < frames; ++k) {
          if (k % every != 0 && k != frames - 1) continue;
          sim.advance_to(k / fps);
          e.add(rd::scene_extent(*sim.scene, *sim.data, renderer.option()));
          progress.update(k + 1, sim.time());
        }
      } catch (const std::exception&) {
      }
      progress.clear();
      renderer.frame(e);
      sim.restart(o);
    }
    rd::remove_frames(o.out);

    Progress progress("render", frames, "frame");
    for (long k = 0; k < frames; ++k) {
      sim.advance_to(k / fps);
      rd::write_png(rd::frame_path(o.out, static_cast<int>(k)), renderer.render(*sim.data));
      progress.update(k + 1, sim.time());
    }
    progress.clear();
    if (!video.empty()) rd::encode_video(o.out, fps, video);  // its directory: check_writable's
    std::printf("render: %ld frames %dx%d in %s%s\n", frames, renderer.width(), renderer.height(), o.out.c_str(),
                video.empty() ? "" : (", video " + video).c_str());
    sim.warn();
    return 0;
  });
}

int snapshot_command(int argc, char** argv) {
  return guarded([&] {
    PictureOptions o;
    double time = 0.0;
    CommandLine cl{"snapshot", "simulate until --time and write one picture (PNG)", {"MODEL.xml"}, {},
                   "Rendering is headless (OSMesa): no display is needed.\n", "MODEL.xml --out F.png [options]"};
    cl.options.push_back(text_option("--out", "F.png", "the picture (its directory is created)", o.out));
    cl.options.push_back(number("--time", "t", "simulated time of the picture [s] after the start, at the step nearest it (the time drawn is printed; default 0: the initial state; from a keyframe with a time, run's CSV and --ctrl-file count that time on top)", time, 0));
    o.add_to(cl);
    const auto pos = cl.parse(argc - 1, argv + 1);  // after the command name
    if (!pos) return 0;
    o.finish();
    {  // (outside probe BB: --out pic.jpg wrote PNG data under that name)
      std::string ext = fs::path(o.out).extension().string();
      std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
      if (ext != ".png") fail("--out: the picture is a PNG: give a name ending in .png, got " + o.out);
    }
    check_writable("--out", o.out);

    Simulation sim((*pos)[0], o);
    rd::Renderer renderer(*sim.scene, o.render);
    warn_renderer(renderer);
    sim.advance_to(time, "snapshot");  // the picture's directory: check_writable's
    rd::write_png(o.out, renderer.render(*sim.data));
    std::printf("snapshot: %s %dx%d at t = %g s\n", o.out.c_str(), renderer.width(), renderer.height(), sim.time());
    sim.warn();
    return 0;
  });
}
