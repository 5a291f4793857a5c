// Input of the viewer window: GLFW callbacks gathered into per-frame events (key presses, mouse
// drags, wheel, right clicks) and the held keys for flying. poll() hands over what happened since the last call.
#pragma once

#include <vector>

#include <glm/glm.hpp>

struct GLFWwindow;

namespace mds::viewer {

enum class DragMode { none, orbit, pan };

struct InputFrame {
  std::vector<int> keys_pressed;  // GLFW_KEY_* pressed (and repeated) since the last poll
  std::vector<int> key_mods;      // modifiers of each press
  glm::dvec2 orbit_delta{0.0};    // pixels dragged with the left button
  glm::dvec2 pan_delta{0.0};      // pixels dragged with the middle button or shift + left
  double wheel = 0.0;             // wheel steps (positive: away from the user = zoom in)
  glm::dvec3 fly{0.0};            // held WASD/QE: right, up, forward in {-1, 0, 1}
  glm::dvec2 cursor{0.0};         // cursor position in framebuffer pixels
  std::vector<glm::dvec2> picks;  // right clicks: where (framebuffer pixels), in order
  bool resized = false;
  bool any() const {
    return !keys_pressed.empty() || !picks.empty() || orbit_delta != glm::dvec2(0.0) || pan_delta != glm::dvec2(0.0) || wheel != 0.0 ||
           fly != glm::dvec3(0.0) || resized;
  }
};

class Input {
 public:
  // Installs the callbacks on `window` (its user pointer is set to this object).
  explicit Input(GLFWwindow* window);
  ~Input();
  Input(const Input&) = delete;
  Input& operator=(const Input&) = delete;

  // Events since the last call plus the current held-key state.
  InputFrame poll();

 private:
  static void on_key(GLFWwindow* w, int key, int scancode, int action, int mods);
  static void on_button(GLFWwindow* w, int button, int action, int mods);
  static void on_cursor(GLFWwindow* w, double x, double y);
  static void on_scroll(GLFWwindow* w, double dx, double dy);
  static void on_resize(GLFWwindow* w, int width, int height);

  GLFWwindow* window_;
  InputFrame pending_;
  DragMode drag_ = DragMode::none;
  glm::dvec2 last_cursor_{0.0};
  bool have_cursor_ = false;
};

}  // namespace mds::viewer
