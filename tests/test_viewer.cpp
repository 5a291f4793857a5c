// `mdstream view` (src/viewer/) end to end in a window on an Xvfb X server (skipped only when
// Xvfb or xdotool is not installed; tests/test_viewer_parts.cpp tests its parts without one):
//   - a --play path replayed to convergence with --screenshot matches a headless `mdstream
//     render` of the path's final camera;
//   - mouse and key input driven by xdotool moves the camera (orbit, wheel zoom) and 'r' resets
//     it, checked on the --record camera path;
//   - a right click names the particle `render --pick` names at that pixel and marks it.
#include <gtest/gtest.h>
#include <png.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "culling/culling_constants.h"
#include "render/camera.h"
#include "render/camera_path.h"
#include "render/scene.h"
#include "store/store_reader.h"
#include "viewer/camera_controller.h"
#include "viewer/color_keys.h"
#include "overlay/axis_tripod.h"
#include "overlay/canvas.h"
#include "overlay/color_legend.h"
#include "viewer/debug_views.h"
#include "viewer/hud.h"
#include "viewer/path_recorder.h"
#include "viewer/slice_keys.h"
#include "viewer/threshold_keys.h"

namespace fs = std::filesystem;
using namespace mds;

namespace {

// ------------------------------------------------------------------------------ windowed tests

bool have_program(const char* name) {
  return std::system(fmt::format("command -v {} >/dev/null 2>&1", name).c_str()) == 0;
}

std::string slurp(const fs::path& p) {
  std::ifstream f(p);
  return std::string(std::istreambuf_iterator<char>(f), {});
}

// Runs a shell command, stderr to `err`; the exit status.
int sh(const std::string& cmd) {
  const int r = std::system(cmd.c_str());
  return WIFEXITED(r) ? WEXITSTATUS(r) : -1;
}

// An Xvfb server on a free display number, killed when the object goes.
class Xvfb {
 public:
  Xvfb() {
    for (int n = 100 + int(::getpid() % 800), tries = 0; tries < 100; ++n, ++tries) {
      if (fs::exists(fmt::format("/tmp/.X{}-lock", n)) || fs::exists(fmt::format("/tmp/.X11-unix/X{}", n))) continue;
      pid_ = ::fork();
      if (pid_ == 0) {
        const std::string disp = ":" + std::to_string(n);
        std::freopen("/dev/null", "w", stderr);
        std::freopen("/dev/null", "w", stdout);
        ::execlp("Xvfb", "Xvfb", disp.c_str(), "-screen", "0", "640x480x24", "-nolisten", "tcp", (char*)nullptr);
        ::_exit(127);
      }
      // Wait until the server accepts connections on its socket (or died: number taken).
      const auto t0 = std::chrono::steady_clock::now();
      while (std::chrono::steady_clock::now() - t0 < std::chrono::seconds(15)) {
        int status = 0;
        if (::waitpid(pid_, &status, WNOHANG) == pid_) {
          pid_ = -1;
          break;
        }
        if (connectable(n)) {
          display_ = n;
          return;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
      }
      stop();
    }
  }
  ~Xvfb() { stop(); }
  bool ok() const { return display_ >= 0; }
  std::string display() const { return ":" + std::to_string(display_); }

 private:
  static bool connectable(int n) {
    const int fd = ::socket(AF_UNIX, SOCK_STREAM, 0);
    if (fd < 0) return false;
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    std::snprintf(addr.sun_path, sizeof addr.sun_path, "/tmp/.X11-unix/X%d", n);
    const bool ok = ::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0;
    ::close(fd);
    return ok;
  }
  void stop() {
    if (pid_ > 0) {
      ::kill(pid_, SIGTERM);
      ::waitpid(pid_, nullptr, 0);
    }
    pid_ = -1;
    display_ = -1;
  }
  pid_t pid_ = -1;
  int display_ = -1;
};

struct Png {
  uint32_t width = 0, height = 0;
  std::vector<uint8_t> rgb;
};

Png read_png(const fs::path& path) {
  png_image img{};
  img.version = PNG_IMAGE_VERSION;
  Png out;
  if (!png_image_begin_read_from_file(&img, path.c_str())) return out;
  img.format = PNG_FORMAT_RGB;
  out.rgb.resize(PNG_IMAGE_SIZE(img));
  if (!png_image_finish_read(&img, nullptr, out.rgb.data(), 0, nullptr)) return {};
  out.width = img.width;
  out.height = img.height;
  return out;
}

// The viewer's screenshot against the headless render of the same camera and look: the same
// image within 8/255 on all but 1 % of the pixels (the window's swapchain path and PNG rounding).
void expect_screenshot_matches(const fs::path& shot, const fs::path& ref, uint32_t W, uint32_t H) {
  const Png a = read_png(shot), b = read_png(ref);
  ASSERT_EQ(a.width, W);
  ASSERT_EQ(a.height, H);
  ASSERT_EQ(b.width, W);
  ASSERT_EQ(b.height, H);
  double sum = 0.0;
  size_t differing = 0, lit = 0;
  for (size_t p = 0; p < size_t(W) * H; ++p) {
    int maxd = 0;
    for (int c = 0; c < 3; ++c) {
      const int d = std::abs(int(a.rgb[3 * p + c]) - int(b.rgb[3 * p + c]));
      sum += d;
      maxd = std::max(maxd, d);
    }
    if (maxd > 8) ++differing;
    if (b.rgb[3 * p] != b.rgb[0] || b.rgb[3 * p + 2] != b.rgb[2]) ++lit;  // not background
  }
  EXPECT_GT(lit, size_t(W) * H / 10) << "the reference shows almost nothing: a wrong camera?";
  EXPECT_LT(sum / (3.0 * W * H), 2.0) << "mean absolute difference (of 255)";
  EXPECT_LT(double(differing) / (W * H), 0.01) << differing << " pixels differ by more than 8/255";
}


class ViewerWindow : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!have_program("Xvfb")) GTEST_SKIP() << "Xvfb is not installed (apt-get install xvfb)";
    dir_ = fs::temp_directory_path() / fmt::format("mds_viewer_{}_{}", ::getpid(),
                                                   ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
    ASSERT_EQ(mdstream(fmt::format("synth --scene porous -n 100000 -q -o {}", (dir_ / "p.lammpstrj").string())), 0)
        << err();
    ASSERT_EQ(mdstream(fmt::format("convert {} -o {}", (dir_ / "p.lammpstrj").string(), store())), 0) << err();
    xvfb_ = std::make_unique<Xvfb>();
    ASSERT_TRUE(xvfb_->ok()) << "Xvfb did not start on any free display";
  }
  void TearDown() override {
    xvfb_.reset();
    if (!dir_.empty()) fs::remove_all(dir_);
  }
  int mdstream(const std::string& args) {
    return sh(fmt::format("{} {} 2>{}", MDSTREAM_BIN, args, (dir_ / "err.txt").string()));
  }
  std::string err() const { return slurp(dir_ / "err.txt"); }
  std::string store() const { return (dir_ / "p.mds").string(); }
  std::string env() const { return "DISPLAY=" + xvfb_->display() + " "; }
  // Replaces store() by 20000 particles of one type in a 30^3 box whose own colours
  // (convert --color) follow the position: (x, y, 1 - z) / 30.
  void use_colored_store() {
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> u(0.0, 30.0);
    std::string text = "20000\nProperties=species:S:1:pos:R:3:color:R:3\n";
    for (int i = 0; i < 20000; ++i) {
      const double x = u(rng), y = u(rng), z = u(rng);
      text += fmt::format("A {:.5f} {:.5f} {:.5f} {:.4f} {:.4f} {:.4f}\n", x, y, z, x / 30, y / 30, 1 - z / 30);
    }
    {
      std::ofstream f(dir_ / "c.xyz");
      f << text;
    }
    fs::remove(store());
    ASSERT_EQ(mdstream(fmt::format("convert {} --color -q -o {}", (dir_ / "c.xyz").string(), store())), 0) << err();
  }
  // The fixture's store replaced by 20000 particles whose property `r2` is their squared distance
  // from the centre of the 30^3 box (convert --property r2).
  void use_property_store() {
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> u(0.0, 30.0);
    std::string text = "20000\nProperties=species:S:1:pos:R:3:r2:R:1\n";
    for (int i = 0; i < 20000; ++i) {
      const double x = u(rng), y = u(rng), z = u(rng);
      text += fmt::format("A {:.5f} {:.5f} {:.5f} {:.4f}\n", x, y, z,
                          (x - 15) * (x - 15) + (y - 15) * (y - 15) + (z - 15) * (z - 15));
    }
    {
      std::ofstream f(dir_ / "p.xyz");
      f << text;
    }
    fs::remove(store());
    ASSERT_EQ(mdstream(fmt::format("convert {} --property r2 --node-size 2000 -q -o {}", (dir_ / "p.xyz").string(),
                                   store())),
              0)
        << err();
  }
  // A 6-frame orbit of the store for a W x H window, saved to path.txt.
  render::CameraPath orbit(uint32_t W, uint32_t H) {
    auto reader = store::StoreReader::open(store());
    EXPECT_TRUE(reader.ok()) << reader.error().message;
    auto scene = render::load_scene(**reader);
    EXPECT_TRUE(scene.ok()) << scene.error().message;
    render::CameraPath path = render::builtin_path(render::BuiltinPath::orbit, scene->bounds, 6, 40.0, double(W) / H);
    EXPECT_EQ(path.frame_count(), 6u);
    EXPECT_TRUE(path.save(dir_ / "path.txt").ok());
    return path;
  }
  // Plays a 6-frame orbit of the store (orbit) in a 160x120 window with `view_args`, then
  // compares its screenshot with `render` of the path's last camera: it matches the one with
  // `same_args`, and more than 5 % of its channels are beyond 24/255 from the one with
  // `other_args` (`why` says what it means when not).
  void expect_window_like_render(const std::string& view_args, const std::string& same_args,
                                 const std::string& other_args, const char* why) {
    const uint32_t W = 160, H = 120;
    const render::CameraPath path = orbit(W, H);
    const fs::path shot = dir_ / "view.png", ref = dir_ / "render.png", other = dir_ / "other.png";
    ASSERT_EQ(sh(fmt::format("{}timeout 50 {} view {} --width {} --height {} --spp 4 --play {} --no-hud --screenshot {} "
                             "{} 2>{}",
                             env(), MDSTREAM_BIN, store(), W, H, (dir_ / "path.txt").string(), shot.string(),
                             view_args, (dir_ / "err.txt").string())),
              0)
        << err();
    for (const auto& [out, args] : {std::pair{ref, same_args}, std::pair{other, other_args}})
      ASSERT_EQ(mdstream(fmt::format("render {} -o {} --width {} --height {} --spp 4 {} {}", store(), out.string(), W,
                                     H, last_camera(path), args)),
                0)
          << err();
    expect_screenshot_matches(shot, ref, W, H);
    const Png a = read_png(shot), t = read_png(other);
    ASSERT_EQ(a.rgb.size(), t.rgb.size());
    size_t differing = 0;
    for (size_t i = 0; i < a.rgb.size(); ++i) differing += std::abs(int(a.rgb[i]) - int(t.rgb[i])) > 24;
    EXPECT_GT(differing, a.rgb.size() / 20) << why;
  }
  // `render` options for the path's last camera (--fov, --camera).
  static std::string last_camera(const render::CameraPath& path) {
    const render::Camera last = path.at(path.frame_count() - 1);
    return fmt::format("--fov {} --camera {},{},{},{},{},{},{},{},{}", last.fov_y_deg, last.eye.x, last.eye.y,
                       last.eye.z, last.target.x, last.target.y, last.target.z, last.up.x, last.up.y, last.up.z);
  }

  fs::path dir_;
  std::unique_ptr<Xvfb> xvfb_;
};

// The window shows exactly what the headless renderer makes: a short path replayed to
// convergence, its screenshot against `mdstream render` of the path's last camera.
TEST_F(ViewerWindow, PlayedPathScreenshotMatchesHeadlessRender) {
  const uint32_t W = 160, H = 120;
  const render::CameraPath path = orbit(W, H);
  const fs::path path_file = dir_ / "path.txt", shot = dir_ / "view.png", ref = dir_ / "render.png";

  // Dynamic resolution with an unreachable target (1 ms): the moving frames render at the
  // smallest scale, upscaled to the window; at rest the full size returns, so the final
  // screenshot must still equal the headless render.
  const fs::path log = dir_ / "frames.csv";
  // Colours other than the defaults, a hidden type and another radius: the viewer must hand them
  // to its renderer and scene as `render` does.
  const std::string look = "--background '#203040' --type-color 1=0.9,0.1,0.1 --hide-type 2 --type-radius 1=0.6";
  ASSERT_EQ(sh(fmt::format("{}timeout 50 {} view {} --width {} --height {} --spp 4 --play {} --no-hud --screenshot {} "
                           "--dynamic-resolution --frame-ms-target 1 --min-scale 0.25 --frame-log {} {} 2>{}",
                           env(), MDSTREAM_BIN, store(), W, H, path_file.string(), shot.string(), log.string(), look,
                           (dir_ / "err.txt").string())),
            0)
      << err();
  {
    std::ifstream f(log);
    std::string line;
    ASSERT_TRUE(std::getline(f, line));
    std::vector<std::string> head;
    for (size_t a = 0, b; a <= line.size(); a = b + 1) {
      b = line.find(',', a);
      if (b == std::string::npos) b = line.size();
      head.push_back(line.substr(a, b - a));
    }
    const auto col = [&](const char* name) { return size_t(std::find(head.begin(), head.end(), name) - head.begin()); };
    const size_t c_frame = col("frame"), c_scale = col("scale"), c_w = col("render_width"), c_h = col("render_height");
    ASSERT_LT(c_h, head.size()) << line;
    std::vector<std::vector<std::string>> rows;
    while (std::getline(f, line)) {
      std::vector<std::string> r;
      for (size_t a = 0, b; a <= line.size(); a = b + 1) {
        b = line.find(',', a);
        if (b == std::string::npos) b = line.size();
        r.push_back(line.substr(a, b - a));
      }
      rows.push_back(r);
    }
    ASSERT_GT(rows.size(), 6u);
    size_t reduced = 0;
    for (const auto& r : rows)
      if (std::stoi(r[c_frame]) >= 1 && std::stoi(r[c_frame]) < 6 && std::stod(r[c_scale]) == 0.25 &&
          std::stoul(r[c_w]) == W / 4 && std::stoul(r[c_h]) == H / 4)
        ++reduced;
    EXPECT_GE(reduced, 4u) << "moving frames 1..5 should render at 1/4 of the window size";
    EXPECT_EQ(std::stod(rows.back()[c_scale]), 1.0);
    EXPECT_EQ(std::stoul(rows.back()[c_w]), W);
    EXPECT_EQ(std::stoul(rows.back()[c_h]), H);
  }
  ASSERT_EQ(mdstream(fmt::format("render {} -o {} --width {} --height {} --spp 4 {} {}", store(), ref.string(), W, H,
                                 last_camera(path), look)),
            0)
      << err();

  expect_screenshot_matches(shot, ref, W, H);
}

// Colour by coordinate in the window: the viewer hands --color-by and --color-range to its
// renderer as `render` does, and the image is not the type colours' one.
TEST_F(ViewerWindow, ColourByCoordinateScreenshotMatchesHeadlessRender) {
  const std::string look = "--color-by z --color-range 5:35";
  expect_window_like_render(look, look, "", "the colormap's image looks like the type colours'");
}

// The particles' own colours in the window (convert --color; --color-by auto, the default, draws
// them): the fixture's store is replaced by one whose colours follow the position, and the
// screenshot matches `render` of it, not its type colours.
TEST_F(ViewerWindow, OwnColoursScreenshotMatchesHeadlessRender) {
  ASSERT_NO_FATAL_FAILURE(use_colored_store());
  expect_window_like_render("", "", "--color-by type", "the window shows the type colours");
}

// --threshold while streaming: the viewer's cache leaves out the nodes whose property histogram
// holds no kept value and thins the others, and the window shows what `render --threshold` draws
// in memory (a ball of the particles within 10 of the centre), not the whole box.
TEST_F(ViewerWindow, StreamedThresholdScreenshotMatchesInMemoryRender) {
  ASSERT_NO_FATAL_FAILURE(use_property_store());
  expect_window_like_render("--threshold :100 --gpu-budget 1MiB", "--threshold :100", "",
                            "the window shows the whole box");
}

// A viewer started in the background under the fixture's Xvfb (ViewerWindow::start), killed if
// a test ends before it exits.
struct RunningViewer {
  pid_t pid = -1;
  bool done = false;
  int status = -1;
  std::string window;  // X window id, for xdotool
  ~RunningViewer() {
    if (pid > 0 && !done) {
      ::kill(pid, SIGKILL);
      ::waitpid(pid, nullptr, 0);
    }
  }
  // Waits up to 20 s for the viewer to exit; true when it did (status in `status`).
  bool wait_exit() {
    const auto t0 = std::chrono::steady_clock::now();
    while (std::chrono::steady_clock::now() - t0 < std::chrono::seconds(20)) {
      if (::waitpid(pid, &status, WNOHANG) == pid) return done = true;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    return false;
  }
};

// `mdstream view STORE ARGS` in the background, stderr to viewer_err.txt; returns once its
// window is visible (the store is loaded and the first frame on its way), with its id.
void start_viewer(const std::string& display_env, const std::string& args, const fs::path& dir, RunningViewer& v) {
  v.pid = ::fork();
  if (v.pid == 0) {
    const std::string cmd = fmt::format("{}exec {} view {} 2>{}", display_env, MDSTREAM_BIN, args,
                                        (dir / "viewer_err.txt").string());
    ::execl("/bin/sh", "sh", "-c", cmd.c_str(), (char*)nullptr);
    ::_exit(127);
  }
  ASSERT_GT(v.pid, 0);
  ASSERT_EQ(sh(display_env + "timeout 20 xdotool search --sync --onlyvisible --name 'mdstream view' > " +
               (dir / "wid.txt").string()),
            0)
      << slurp(dir / "viewer_err.txt");
  const std::string wid = slurp(dir / "wid.txt");
  v.window = wid.substr(0, wid.find('\n'));
}

void pause_for_viewer() { std::this_thread::sleep_for(std::chrono::milliseconds(1500)); }

// `mdstream view STORE ARGS` under `display_env`: the keys pressed one by one (xdotool, 400 ms
// apart) once its window shows, then Esc; the viewer must exit with 0. Returns its stderr.
std::string view_keys_then_quit(const std::string& display_env, const std::string& args,
                                const std::vector<std::string>& keys, const fs::path& dir) {
  RunningViewer v;
  start_viewer(display_env, args, dir, v);
  if (::testing::Test::HasFatalFailure()) return {};
  const std::string x = display_env + "timeout 20 xdotool windowfocus --sync " + v.window + " key ";
  pause_for_viewer();
  for (const std::string& key : keys) {
    EXPECT_EQ(sh(x + key), 0) << key;
    std::this_thread::sleep_for(std::chrono::milliseconds(400));
  }
  pause_for_viewer();
  EXPECT_EQ(sh(x + "Escape"), 0);
  const fs::path log = dir / "viewer_err.txt";
  EXPECT_TRUE(v.wait_exit()) << "the viewer did not exit on Esc\n" << slurp(log);
  EXPECT_TRUE(WIFEXITED(v.status) && WEXITSTATUS(v.status) == 0) << slurp(log);
  return slurp(log);
}

// --screenshot after Esc waits for the view to settle: a streamed view on a slow disk (150 ms a
// read) quit the moment its window shows still saves the image `render` draws through the same
// budget, not the frame shown when the key came.
TEST_F(ViewerWindow, ScreenshotWaitsForASlowStreamedViewToSettle) {
  if (!have_program("xdotool")) GTEST_SKIP() << "xdotool is not installed (apt-get install xdotool)";
  const uint32_t W = 160, H = 120;
  const fs::path shot = dir_ / "slow.png", ref = dir_ / "slow_render.png", log = dir_ / "viewer_err.txt";
  const std::string look =
      fmt::format("--width {} --height {} --spp 1 --no-cull --gpu-budget 256KiB --camera 45,-20,50,15,15,15", W, H);
  RunningViewer v;
  ASSERT_NO_FATAL_FAILURE(start_viewer(env(), store() + " " + look + " --io-latency-ms 150 --no-hud --screenshot " +
                                                  shot.string(), dir_, v));
  ASSERT_EQ(sh(env() + "timeout 20 xdotool windowfocus --sync " + v.window + " key Escape"), 0);
  ASSERT_TRUE(v.wait_exit()) << "the viewer did not exit on Esc\n" << slurp(log);
  ASSERT_TRUE(WIFEXITED(v.status) && WEXITSTATUS(v.status) == 0) << slurp(log);
  ASSERT_EQ(mdstream(fmt::format("render {} -o {} {}", store(), ref.string(), look)), 0) << err();
  expect_screenshot_matches(shot, ref, W, H);
}

// Input events (X11, through xdotool) move the camera: a left drag orbits, the wheel zooms,
// 'r' resets; the recorded path shows all three.
TEST_F(ViewerWindow, XdotoolInputMovesTheCamera) {
  if (!have_program("xdotool")) GTEST_SKIP() << "xdotool is not installed (apt-get install xdotool)";
  const fs::path rec = dir_ / "rec.txt", log = dir_ / "viewer_err.txt";
  RunningViewer v;
  const fs::path shot = dir_ / "hud.png";
  ASSERT_NO_FATAL_FAILURE(start_viewer(env(), store() + " --width 160 --height 120 --spp 1 --no-cull --record " +
                                                  rec.string() + " --screenshot " + shot.string(), dir_, v));
  const std::string x = env() + "timeout 20 xdotool ", wid = v.window;
  pause_for_viewer();
  // Left drag to the right (orbit), then wheel up twice (zoom in), then 'r', then Esc.
  ASSERT_EQ(sh(x + "mousemove --window " + wid + " 40 60 mousedown 1 mousemove --window " + wid +
               " 90 60 mousemove --window " + wid + " 120 60 mouseup 1"),
            0);
  pause_for_viewer();
  ASSERT_EQ(sh(x + "mousemove --window " + wid + " 80 60 click 4 click 4"), 0);
  pause_for_viewer();
  ASSERT_EQ(sh(x + "windowfocus --sync " + wid + " key r"), 0);
  pause_for_viewer();
  ASSERT_EQ(sh(x + "windowfocus --sync " + wid + " key Escape"), 0);
  ASSERT_TRUE(v.wait_exit()) << "the viewer did not exit on Esc\n" << slurp(log);
  ASSERT_TRUE(WIFEXITED(v.status) && WEXITSTATUS(v.status) == 0) << slurp(log);

  auto path = render::CameraPath::load(rec);
  ASSERT_TRUE(path.ok()) << path.error().message;
  const auto& keys = path->keys();
  ASSERT_GE(keys.size(), 2u);
  const render::Camera home = keys.front().camera;
  const double d0 = glm::length(home.eye - home.target);
  bool orbited = false, zoomed = false;
  for (const auto& k : keys) {
    const double d = glm::length(k.camera.eye - k.camera.target);
    if (glm::length(k.camera.eye - home.eye) > 1e-3 * d0 && std::abs(d - d0) < 1e-6 * d0 &&
        glm::length(k.camera.target - home.target) < 1e-9 * d0)
      orbited = true;
    if (d < 0.9 * d0) zoomed = true;
  }
  EXPECT_TRUE(orbited) << "no keyframe orbits the start camera\n" << path->to_text();
  EXPECT_TRUE(zoomed) << "no keyframe is closer to the target\n" << path->to_text();
  EXPECT_TRUE(viewer::same_camera(keys.back().camera, home)) << "'r' did not reset the view\n" << path->to_text();
  // With the HUD the coordinate tripod of the camera shown sits in the bottom-left corner: the
  // start view looks along -z, so x (red) points right of the panel's centre and y (green) up.
  const Png png = read_png(shot);
  ASSERT_GT(png.width, 0u) << shot;
  const auto at = [&](int px, int py) {
    const uint8_t* p = &png.rgb[3 * (size_t(py) * png.width + size_t(px))];
    return overlay::Rgba8(p[0], p[1], p[2], 255);
  };
  const overlay::PixelBox b = overlay::tripod_box(png.width, png.height, overlay::LegendCorner::bottom_left);
  ASSERT_FALSE(b.empty());
  const auto axes = overlay::tripod_axes(home);
  const auto color_of = [&](char name) {
    for (const auto& a : axes)
      if (a.name == name) return a.color;
    return overlay::Rgba8{};
  };
  const int cx = (b.x0 + b.x1) / 2, cy = (b.y0 + b.y1) / 2;
  int red_right = 0, green_up = 0;
  for (int d = 4; d < 18; ++d) {
    red_right += at(cx + d, cy) == color_of('x');
    green_up += at(cx, cy - d) == color_of('y');
  }
  EXPECT_GE(red_right, 10);
  EXPECT_GE(green_up, 10);
}

// The slice keys in the window: '.' three times and ',' once move the slab two steps up its
// normal, '/' inverts it; the viewer prints the options of the cut it shows, and the screenshot
// equals `mdstream render` with them. Dynamic resolution (the default) with --spp 1: the frame
// after a change must not stay at the reduced size of a moving frame.
TEST_F(ViewerWindow, SliceKeysMoveTheCutAsRenderDrawsIt) {
  if (!have_program("xdotool")) GTEST_SKIP() << "xdotool is not installed (apt-get install xdotool)";
  const uint32_t W = 160, H = 120;
  const fs::path shot = dir_ / "view.png", ref = dir_ / "render.png", log = dir_ / "viewer_err.txt";
  const std::string look = fmt::format("--width {} --height {} --spp 1 --no-cull --camera 90,-60,80,31,31,29", W, H);
  RunningViewer v;
  ASSERT_NO_FATAL_FAILURE(start_viewer(
      env(), store() + " " + look + " --no-hud --slice 0,0,1,20,6 --screenshot " + shot.string(), dir_, v));
  const std::string x = env() + "timeout 20 xdotool windowfocus --sync " + v.window + " key ";
  pause_for_viewer();
  ASSERT_EQ(sh(x + "period period period comma"), 0);
  pause_for_viewer();
  ASSERT_EQ(sh(x + "slash"), 0);
  pause_for_viewer();
  ASSERT_EQ(sh(x + "Escape"), 0);
  ASSERT_TRUE(v.wait_exit()) << "the viewer did not exit on Esc\n" << slurp(log);
  ASSERT_TRUE(WIFEXITED(v.status) && WEXITSTATUS(v.status) == 0) << slurp(log);

  // The last line the viewer printed: the options of what it showed.
  std::string options;
  {
    std::ifstream f(log);
    for (std::string line; std::getline(f, line);)
      if (line.rfind("mdstream view: --slice ", 0) == 0) options = line.substr(std::string("mdstream view: ").size());
  }
  auto reader = store::StoreReader::open(store());
  ASSERT_TRUE(reader.ok()) << reader.error().message;
  const store::FileHeader& h = (*reader)->header();
  const double step = (h.bounds_max[2] - h.bounds_min[2]) / viewer::kSliceStepsPerExtent;
  const std::string prefix = "--slice 0,0,1,";
  ASSERT_EQ(options.rfind(prefix, 0), 0u) << slurp(log);
  const double d = std::stod(options.substr(prefix.size()));
  EXPECT_NEAR(d, 20.0 + 2.0 * step, 1e-3 * step) << options;
  EXPECT_NE(options.find(",6,invert"), std::string::npos) << options;

  ASSERT_EQ(mdstream(fmt::format("render {} -o {} {} {}", store(), ref.string(), look, options)), 0) << err();
  expect_screenshot_matches(shot, ref, W, H);
}

// A right click names the particle under the cursor: the viewer prints it, `render --pick` of the
// same pixel, camera and size names the same particle, and the screenshot (the HUD on) marks it
// with a magenta cross around that pixel. A second right click also prints the distance between
// the two particles' centres.
TEST_F(ViewerWindow, RightClickNamesTheParticleRenderPickNames) {
  if (!have_program("xdotool")) GTEST_SKIP() << "xdotool is not installed (apt-get install xdotool)";
  const uint32_t W = 320, H = 240;
  const glm::uvec2 first(150, 120), second(190, 150);
  const fs::path shot = dir_ / "view.png", log = dir_ / "viewer_err.txt", picks = dir_ / "picks.txt";
  const std::string look = fmt::format("--width {} --height {} --spp 1 --no-cull --camera 90,-60,80,31,31,29", W, H);
  RunningViewer v;
  ASSERT_NO_FATAL_FAILURE(start_viewer(env(), store() + " " + look + " --screenshot " + shot.string(), dir_, v));
  const std::string x = env() + "timeout 20 xdotool ";
  pause_for_viewer();
  for (const glm::uvec2 p : {first, second}) {
    ASSERT_EQ(sh(fmt::format("{}mousemove --window {} {} {} click 3", x, v.window, p.x, p.y)), 0);
    pause_for_viewer();
  }
  ASSERT_EQ(sh(x + "windowfocus --sync " + v.window + " key Escape"), 0);
  ASSERT_TRUE(v.wait_exit()) << "the viewer did not exit on Esc\n" << slurp(log);
  ASSERT_TRUE(WIFEXITED(v.status) && WEXITSTATUS(v.status) == 0) << slurp(log);

  // "mdstream view: pick X,Y: node N particle K (store index I) type ..., distance D[; L from node M particle J]"
  std::vector<std::string> lines;
  {
    std::ifstream f(log);
    for (std::string l; std::getline(f, l);)
      if (l.rfind("mdstream view: pick ", 0) == 0) lines.push_back(l);
  }
  ASSERT_EQ(lines.size(), 2u) << slurp(log);
  ASSERT_EQ(sh(fmt::format("{} render {} -o {} {} --pick {},{} --pick {},{} > {} 2>{}", MDSTREAM_BIN, store(),
                           (dir_ / "r.png").string(), look, first.x, first.y, second.x, second.y, picks.string(),
                           (dir_ / "err.txt").string())),
            0)
      << err();
  std::vector<nlohmann::json> answers;
  {
    std::ifstream f(picks);
    for (std::string l; std::getline(f, l);) answers.push_back(nlohmann::json::parse(l));
  }
  ASSERT_EQ(answers.size(), 2u);
  glm::dvec3 centre[2];
  for (size_t i = 0; i < 2; ++i) {
    const glm::uvec2 p = i == 0 ? first : second;
    const std::string head = fmt::format("mdstream view: pick {},{}: node ", p.x, p.y);
    ASSERT_EQ(lines[i].rfind(head, 0), 0u) << lines[i];
    unsigned node = 0, particle = 0;
    ASSERT_EQ(std::sscanf(lines[i].c_str() + head.size(), "%u particle %u", &node, &particle), 2) << lines[i];
    const nlohmann::json& q = answers[i]["particle"];
    ASSERT_FALSE(q.is_null()) << answers[i].dump();
    EXPECT_EQ(q["node"].get<unsigned>(), node) << lines[i];
    EXPECT_EQ(q["index_in_node"].get<unsigned>(), particle) << lines[i];
    for (int a = 0; a < 3; ++a) centre[i][a] = q["position"][a].get<double>();
  }
  const size_t semi = lines[1].rfind("; ");
  ASSERT_NE(semi, std::string::npos) << lines[1];
  double distance = 0.0;
  unsigned before_node = 0, before_particle = 0;
  ASSERT_EQ(std::sscanf(lines[1].c_str() + semi + 2, "%lf from node %u particle %u", &distance, &before_node,
                        &before_particle),
            3)
      << lines[1];
  EXPECT_EQ(before_node, answers[0]["particle"]["node"].get<unsigned>());
  EXPECT_EQ(before_particle, answers[0]["particle"]["index_in_node"].get<unsigned>());
  EXPECT_NEAR(distance, glm::length(centre[1] - centre[0]), 1e-5 * glm::length(centre[1] - centre[0])) << lines[1];

  const Png a = read_png(shot);
  ASSERT_EQ(a.width, W);
  size_t cross = 0;
  for (uint32_t py = second.y - 40; py < second.y + 40; ++py)
    for (uint32_t px = second.x - 40; px < second.x + 40; ++px) {
      const uint8_t* c = &a.rgb[3 * (size_t(py) * W + px)];
      cross += c[0] == 255 && c[1] == 0 && c[2] == 255;
    }
  EXPECT_GE(cross, 20u) << "no magenta cross around the picked particle";
}

// The L key switches ambient occlusion on in the window: the screenshot equals `mdstream render
// --ao on` of the same camera (and differs from the image without).
TEST_F(ViewerWindow, AoKeyShowsWhatRenderDrawsWithAo) {
  if (!have_program("xdotool")) GTEST_SKIP() << "xdotool is not installed (apt-get install xdotool)";
  const uint32_t W = 160, H = 120;
  const fs::path shot = dir_ / "view.png", ref = dir_ / "render.png", plain = dir_ / "plain.png";
  const fs::path log = dir_ / "viewer_err.txt";
  const std::string look = fmt::format("--width {} --height {} --spp 1 --no-cull --camera 40,-25,45,25,25,15", W, H);
  RunningViewer v;
  ASSERT_NO_FATAL_FAILURE(start_viewer(env(), store() + " " + look + " --no-hud --screenshot " + shot.string(), dir_, v));
  const std::string x = env() + "timeout 20 xdotool windowfocus --sync " + v.window + " key ";
  pause_for_viewer();
  ASSERT_EQ(sh(x + "l"), 0);
  pause_for_viewer();
  ASSERT_EQ(sh(x + "Escape"), 0);
  ASSERT_TRUE(v.wait_exit()) << "the viewer did not exit on Esc\n" << slurp(log);
  ASSERT_TRUE(WIFEXITED(v.status) && WEXITSTATUS(v.status) == 0) << slurp(log);
  ASSERT_EQ(mdstream(fmt::format("render {} -o {} {} --ao on", store(), ref.string(), look)), 0) << err();
  expect_screenshot_matches(shot, ref, W, H);
  ASSERT_EQ(mdstream(fmt::format("render {} -o {} {}", store(), plain.string(), look)), 0) << err();
  const Png a = read_png(shot), p = read_png(plain);
  ASSERT_EQ(a.rgb.size(), p.rgb.size());
  size_t darker = 0;
  for (size_t i = 0; i < a.rgb.size(); ++i) darker += int(a.rgb[i]) + 24 < int(p.rgb[i]);
  EXPECT_GT(darker, a.rgb.size() / 50) << "the window shows no ambient occlusion";
}

// V and M in the window: two V presses (type -> x -> y on a store without colours or property)
// and an M (viridis -> plasma) show what `render --color-by y --colormap plasma` draws, and the
// viewer prints those options on stderr.
TEST_F(ViewerWindow, ColourKeysShowWhatRenderDrawsWithThoseOptions) {
  if (!have_program("xdotool")) GTEST_SKIP() << "xdotool is not installed (apt-get install xdotool)";
  const uint32_t W = 160, H = 120;
  const fs::path shot = dir_ / "view.png", ref = dir_ / "render.png";
  const std::string look = fmt::format("--width {} --height {} --spp 1 --no-cull --camera 40,-25,45,25,25,15", W, H);
  std::string said;
  ASSERT_NO_FATAL_FAILURE(
      said = view_keys_then_quit(env(), store() + " " + look + " --no-hud --screenshot " + shot.string(), {"v", "v", "m"}, dir_));
  EXPECT_NE(said.find("mdstream view: --color-by x\n"), std::string::npos) << said;
  EXPECT_NE(said.find("mdstream view: --color-by y\n"), std::string::npos) << said;
  EXPECT_NE(said.find("mdstream view: --color-by y --colormap plasma\n"), std::string::npos) << said;
  ASSERT_EQ(mdstream(fmt::format("render {} -o {} {} --color-by y --colormap plasma", store(), ref.string(), look)), 0)
      << err();
  expect_screenshot_matches(shot, ref, W, H);
}

// The key U turns the simulation cell on and off in place: started with --cell off, one press
// shows what `render` draws by default (the store's cell), streaming through a budget; a second
// and third press off and on again.
TEST_F(ViewerWindow, CellKeyShowsWhatRenderDrawsWithTheCell) {
  if (!have_program("xdotool")) GTEST_SKIP() << "xdotool is not installed (apt-get install xdotool)";
  const uint32_t W = 160, H = 120;
  const fs::path shot = dir_ / "view.png", ref = dir_ / "render.png", off = dir_ / "off.png";
  const std::string look =
      fmt::format("--width {} --height {} --spp 1 --no-cull --gpu-budget 256KiB --camera 60,-30,70,15,15,15", W, H);
  std::string said;
  ASSERT_NO_FATAL_FAILURE(said = view_keys_then_quit(
                              env(), store() + " " + look + " --cell off --no-hud --screenshot " + shot.string(),
                              {"u", "u", "u"}, dir_));
  const size_t on1 = said.find("mdstream view: --cell on\n");
  const size_t off1 = said.find("mdstream view: --cell off\n", on1 == std::string::npos ? 0 : on1);
  const size_t on2 = said.find("mdstream view: --cell on\n", off1 == std::string::npos ? 0 : off1);
  EXPECT_TRUE(on1 != std::string::npos && off1 != std::string::npos && on2 != std::string::npos) << said;
  ASSERT_EQ(mdstream(fmt::format("render {} -o {} {}", store(), ref.string(), look)), 0) << err();
  expect_screenshot_matches(shot, ref, W, H);
  // The reference differs from the image without the cell: the test sees the lines.
  ASSERT_EQ(mdstream(fmt::format("render {} -o {} {} --cell off", store(), off.string(), look)), 0) << err();
  EXPECT_NE(slurp(ref), slurp(off));
}

// Streaming, the pool holds the particles' own colours only while they are drawn: V out of them
// (to x) and, four presses later, back into them makes the cache again each time, and the window
// then shows what `render` draws with its default (the colours) through the same budget.
TEST_F(ViewerWindow, ColourKeyIntoAndOutOfOwnColoursWhileStreaming) {
  if (!have_program("xdotool")) GTEST_SKIP() << "xdotool is not installed (apt-get install xdotool)";
  ASSERT_NO_FATAL_FAILURE(use_colored_store());
  const uint32_t W = 160, H = 120;
  const fs::path shot = dir_ / "view.png", ref = dir_ / "render.png";
  const std::string look =
      fmt::format("--width {} --height {} --spp 1 --no-cull --gpu-budget 256KiB --camera 45,-20,50,15,15,15", W, H);
  std::string said;
  ASSERT_NO_FATAL_FAILURE(said = view_keys_then_quit(env(), store() + " " + look + " --no-hud --screenshot " + shot.string(),
                                                     {"v", "v", "v", "v", "v"}, dir_));
  for (const char* o : {"--color-by x\n", "--color-by y\n", "--color-by z\n", "--color-by type\n", "--color-by color\n"})
    EXPECT_NE(said.find(std::string("mdstream view: ") + o), std::string::npos) << o << said;
  ASSERT_EQ(mdstream(fmt::format("render {} -o {} {}", store(), ref.string(), look)), 0) << err();
  expect_screenshot_matches(shot, ref, W, H);
}

// The threshold keys in the window, streaming: X 15 times raises the lower bound of a store's
// property (r2, the squared distance from the centre) by 15 steps from its smallest value,
// Shift+Z lowers the upper bound one step from its largest, I inverts it (a ball about the centre
// and the box's corners are left); each change makes the
// cache again. The viewer prints the option of the threshold it shows, which is the one
// step_threshold gives, and the screenshot equals `mdstream render` with it in memory.
TEST_F(ViewerWindow, ThresholdKeysMoveTheBoundsAsRenderDrawsThem) {
  if (!have_program("xdotool")) GTEST_SKIP() << "xdotool is not installed (apt-get install xdotool)";
  ASSERT_NO_FATAL_FAILURE(use_property_store());
  const uint32_t W = 160, H = 120;
  const fs::path shot = dir_ / "view.png", ref = dir_ / "render.png", log = dir_ / "viewer_err.txt";
  const std::string look = fmt::format("--width {} --height {} --spp 1 --no-cull --camera 45,-20,50,15,15,15", W, H);
  RunningViewer v;
  ASSERT_NO_FATAL_FAILURE(start_viewer(
      env(), store() + " " + look + " --gpu-budget 1MiB --no-hud --screenshot " + shot.string(), dir_, v));
  const std::string x = env() + "timeout 20 xdotool windowfocus --sync " + v.window + " key ";
  pause_for_viewer();
  ASSERT_EQ(sh(x + "x x x x x x x x x x x x x x x"), 0);
  pause_for_viewer();
  ASSERT_EQ(sh(x + "shift+z"), 0);
  pause_for_viewer();
  ASSERT_EQ(sh(x + "i"), 0);
  pause_for_viewer();
  ASSERT_EQ(sh(x + "Escape"), 0);
  ASSERT_TRUE(v.wait_exit()) << "the viewer did not exit on Esc\n" << slurp(log);
  ASSERT_TRUE(WIFEXITED(v.status) && WEXITSTATUS(v.status) == 0) << slurp(log);

  std::string option;
  {
    std::ifstream f(log);
    for (std::string line; std::getline(f, line);)
      if (line.rfind("mdstream view: --threshold ", 0) == 0) option = line.substr(std::string("mdstream view: ").size());
  }
  auto reader = store::StoreReader::open(store());
  ASSERT_TRUE(reader.ok()) << reader.error().message;
  const store::FileHeader& h = (*reader)->header();
  const store::Threshold want = viewer::step_threshold(
      viewer::step_threshold(std::nullopt, 15.0, -1.0, false, h.property_min, h.property_max), 0.0, 0.0, true,
      h.property_min, h.property_max);
  EXPECT_EQ(option, viewer::threshold_option(want)) << slurp(log);
  ASSERT_EQ(mdstream(fmt::format("render {} -o {} {} {}", store(), ref.string(), look, option)), 0) << err();
  expect_screenshot_matches(shot, ref, W, H);
}

}  // namespace

namespace {

// A series of three stores (porous, gas, shell) indexed by a hand-written .series file, as
// ParaView users write one: the arrow keys step through it, and the frame shown equals `render
// --series-frames K` of that frame with the same camera; Space plays it in a loop.
class ViewerSeries : public ViewerWindow {
 protected:
  void SetUp() override {
    ViewerWindow::SetUp();
    if (IsSkipped() || HasFatalFailure()) return;
    for (const char* scene : {"gas", "shell"}) {
      const fs::path dump = dir_ / fmt::format("{}.lammpstrj", scene);
      ASSERT_EQ(mdstream(fmt::format("synth --scene {} -n 20000 -q -o {}", scene, dump.string())), 0) << err();
      ASSERT_EQ(mdstream(fmt::format("convert {} -q -o {}", dump.string(), (dir_ / (std::string(scene) + ".mds")).string())), 0)
          << err();
    }
    std::ofstream(series()) << R"({ "file-series-version": "1.0", "files": [
      { "name": "p.mds", "time": 0 }, { "name": "gas.mds", "time": 10 }, { "name": "shell.mds", "time": 20.5 } ] })";
  }
  std::string series() const { return (dir_ / "run.series").string(); }
  // `mdstream view SERIES ARGS --frame-log FRAMES`, stderr to `log`, until it exits; its status.
  int view_series(const std::string& args, const fs::path& frames, const fs::path& log) const {
    return sh(env() + MDSTREAM_BIN + " view " + series() + " " + args + " --frame-log " + frames.string() + " 2>" +
              log.string());
  }
  // The rows of a --frame-log CSV, each a column name -> value map (the header names them).
  static std::vector<std::map<std::string, std::string>> read_frame_log(const fs::path& path) {
    auto split = [](const std::string& line) {
      std::vector<std::string> v;
      for (size_t a = 0, b; a <= line.size(); a = b + 1) {
        b = line.find(',', a);
        if (b == std::string::npos) b = line.size();
        v.push_back(line.substr(a, b - a));
      }
      return v;
    };
    std::ifstream f(path);
    std::string line;
    std::vector<std::map<std::string, std::string>> rows;
    if (!std::getline(f, line)) return rows;
    const std::vector<std::string> cols = split(line);
    while (std::getline(f, line)) {
      const std::vector<std::string> v = split(line);
      std::map<std::string, std::string> row;
      for (size_t i = 0; i < cols.size(); ++i) row[cols[i]] = i < v.size() ? v[i] : "";
      rows.push_back(std::move(row));
    }
    return rows;
  }
  // The --series-frames values the viewer printed, in order.
  std::vector<std::string> printed_frames(const fs::path& log) const {
    std::vector<std::string> v;
    std::ifstream f(log);
    const std::string prefix = "mdstream view: --series-frames ";
    for (std::string line; std::getline(f, line);)
      if (line.rfind(prefix, 0) == 0) v.push_back(line.substr(prefix.size(), line.find(' ', prefix.size()) - prefix.size()));
    return v;
  }
};

TEST_F(ViewerSeries, ArrowKeysStepTheFramesAsRenderDrawsThem) {
  if (!have_program("xdotool")) GTEST_SKIP() << "xdotool is not installed (apt-get install xdotool)";
  const uint32_t W = 160, H = 120;
  const fs::path shot = dir_ / "view.png", ref = dir_ / "render.png", log = dir_ / "viewer_err.txt";
  const std::string look = fmt::format("--width {} --height {} --spp 1 --no-cull --camera 90,-60,80,31,31,29", W, H);
  RunningViewer v;
  ASSERT_NO_FATAL_FAILURE(start_viewer(env(), series() + " " + look + " --screenshot " + shot.string(), dir_, v));
  const std::string x = env() + "timeout 20 xdotool windowfocus --sync " + v.window + " key ";
  pause_for_viewer();
  ASSERT_EQ(sh(x + "Right Right"), 0);
  pause_for_viewer();
  ASSERT_EQ(sh(x + "End Left h"), 0);  // h: the HUD off for the comparison
  pause_for_viewer();
  ASSERT_EQ(sh(x + "Escape"), 0);
  ASSERT_TRUE(v.wait_exit()) << "the viewer did not exit on Esc\n" << slurp(log);
  ASSERT_TRUE(WIFEXITED(v.status) && WEXITSTATUS(v.status) == 0) << slurp(log);
  const auto printed = printed_frames(log);
  ASSERT_FALSE(printed.empty()) << slurp(log);
  EXPECT_EQ(printed.back(), "1") << slurp(log);
  EXPECT_NE(slurp(log).find("(gas.mds, time 10)"), std::string::npos) << slurp(log);
  ASSERT_EQ(mdstream(fmt::format("render {} --series-frames 1 -o {} {}", series(), ref.string(), look)), 0) << err();
  expect_screenshot_matches(shot, ref, W, H);
}

TEST_F(ViewerSeries, SpacePlaysTheSeriesInALoop) {
  if (!have_program("xdotool")) GTEST_SKIP() << "xdotool is not installed (apt-get install xdotool)";
  const fs::path log = dir_ / "viewer_err.txt";
  RunningViewer v;
  ASSERT_NO_FATAL_FAILURE(start_viewer(
      env(), series() + " --series-frames 1: --width 96 --height 72 --spp 1 --no-cull --no-hud", dir_, v));
  const std::string x = env() + "timeout 20 xdotool windowfocus --sync " + v.window + " key ";
  pause_for_viewer();
  ASSERT_EQ(sh(x + "space"), 0);
  for (int i = 0; i < 40 && printed_frames(log).size() < 3; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(250));
  ASSERT_EQ(sh(x + "space Escape"), 0);
  ASSERT_TRUE(v.wait_exit()) << "the viewer did not exit on Esc\n" << slurp(log);
  const auto printed = printed_frames(log);
  ASSERT_GE(printed.size(), 3u) << slurp(log);
  // The picked frames are 1 and 2 of the series: the play goes 1 -> 2 -> 1 -> ...
  EXPECT_EQ(printed[0], "2");
  EXPECT_EQ(printed[1], "1");
  EXPECT_EQ(printed[2], "2");
}

TEST_F(ViewerSeries, PlaySeriesStepsOnOnceACappedViewHasItsSamples) {
  // --max-iterations 2 < --converge-iterations 3: no view converges; each settles at the cap
  // (FrameReport::settled) and the play goes on. The frame log names the frame shown and the
  // time its store took to load.
  const fs::path log = dir_ / "viewer_err.txt", frames = dir_ / "frames.csv";
  ASSERT_EQ(view_series("--play-series --max-iterations 2 --width 96 --height 72 --spp 2 --no-hud --exit-after-frames 30",
                        frames, log),
            0)
      << slurp(log);
  const auto printed = printed_frames(log);
  ASSERT_GE(printed.size(), 3u) << slurp(log);
  EXPECT_EQ(printed[0], "1");
  EXPECT_EQ(printed[1], "2");
  EXPECT_EQ(printed[2], "0");
  const auto rows = read_frame_log(frames);
  ASSERT_EQ(rows.size(), 30u);
  ASSERT_TRUE(rows[0].count("series_frame") && rows[0].count("reload_ms"));
  EXPECT_EQ(rows[0].at("series_frame"), "0");
  std::vector<std::string> shown;  // series_frame of the rows whose frame loaded a store
  for (const auto& r : rows)
    if (std::stod(r.at("reload_ms")) > 0.0) shown.push_back(r.at("series_frame"));
  ASSERT_GE(shown.size(), 3u);
  EXPECT_EQ(std::vector<std::string>(shown.begin(), shown.begin() + 3), std::vector<std::string>(printed.begin(), printed.begin() + 3));
}

TEST_F(ViewerSeries, StreamingStepsShowTheFrameBeforeUntilTheNextIsComplete) {
  // Streamed with slow reads (--io-latency-ms): after each step the new store's first frames
  // have nodes missing; the viewer shows the frame before (held) until the new view is complete.
  const fs::path log = dir_ / "viewer_err.txt", frames = dir_ / "frames.csv";
  ASSERT_EQ(view_series("--play-series --gpu-budget 64MiB --io-latency-ms 40 --max-iterations 2 --width 96 --height 72"
                        " --spp 1 --no-hud --exit-after-frames 160",
                        frames, log),
            0)
      << slurp(log);
  const auto rows = read_frame_log(frames);
  ASSERT_FALSE(rows.empty());
  ASSERT_TRUE(rows[0].count("held"));
  int steps = 0, incomplete_after_step = 0, held_rows = 0;
  for (const auto& r : rows) {
    const bool step = std::stod(r.at("reload_ms")) > 0.0, complete = r.at("complete") == "1", held = r.at("held") == "1";
    held_rows += held;
    if (steps > 0 && !step && !complete) {
      ++incomplete_after_step;
      EXPECT_TRUE(held) << "an incomplete view shown after a step, frame " << r.at("frame");
    }
    if (step) {
      ++steps;
      EXPECT_TRUE(held) << "the step's frame keeps the image before, frame " << r.at("frame");
    }
  }
  EXPECT_GE(steps, 2) << slurp(log);
  EXPECT_GT(incomplete_after_step, 0) << "the reads were too fast to test the hold";
  EXPECT_GT(held_rows, steps);
}

TEST_F(ViewerSeries, PlaySeriesOnAStoreIsAnError) {
  const fs::path log = dir_ / "viewer_err.txt";
  EXPECT_NE(sh(env() + MDSTREAM_BIN + " view " + (dir_ / "gas.mds").string() + " --play-series --exit-after-frames 2 2>" +
               log.string()),
            0);
  EXPECT_NE(slurp(log).find("--play-series"), std::string::npos) << slurp(log);
  EXPECT_NE(slurp(log).find("gas.mds"), std::string::npos) << slurp(log);
}

}  // namespace
