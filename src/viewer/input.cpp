#include "viewer/input.h"

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

namespace mds::viewer {

namespace {
Input* self(GLFWwindow* w) { return static_cast<Input*>(glfwGetWindowUserPointer(w)); }

// Window coordinates -> framebuffer pixels (HiDPI: they differ).
glm::dvec2 to_pixels(GLFWwindow* w, double x, double y) {
  int ww = 0, wh = 0, fw = 0, fh = 0;
  glfwGetWindowSize(w, &ww, &wh);
  glfwGetFramebufferSize(w, &fw, &fh);
  const double sx = ww > 0 ? double(fw) / ww : 1.0, sy = wh > 0 ? double(fh) / wh : 1.0;
  return {x * sx, y * sy};
}
}  // namespace

Input::Input(GLFWwindow* window) : window_(window) {
  glfwSetWindowUserPointer(window_, this);
  glfwSetKeyCallback(window_, &Input::on_key);
  glfwSetMouseButtonCallback(window_, &Input::on_button);
  glfwSetCursorPosCallback(window_, &Input::on_cursor);
  glfwSetScrollCallback(window_, &Input::on_scroll);
  glfwSetFramebufferSizeCallback(window_, &Input::on_resize);
}

Input::~Input() {
  glfwSetKeyCallback(window_, nullptr);
  glfwSetMouseButtonCallback(window_, nullptr);
  glfwSetCursorPosCallback(window_, nullptr);
  glfwSetScrollCallback(window_, nullptr);
  glfwSetFramebufferSizeCallback(window_, nullptr);
  glfwSetWindowUserPointer(window_, nullptr);
}

InputFrame Input::poll() {
  InputFrame f = std::move(pending_);
  pending_ = {};
  auto held = [&](int key) { return glfwGetKey(window_, key) == GLFW_PRESS ? 1.0 : 0.0; };
  f.fly = {held(GLFW_KEY_D) - held(GLFW_KEY_A), held(GLFW_KEY_E) - held(GLFW_KEY_Q),
           held(GLFW_KEY_W) - held(GLFW_KEY_S)};
  double x = 0, y = 0;
  glfwGetCursorPos(window_, &x, &y);
  f.cursor = to_pixels(window_, x, y);
  return f;
}

void Input::on_key(GLFWwindow* w, int key, int, int action, int mods) {
  Input* in = self(w);
  if (!in || action == GLFW_RELEASE) return;
  in->pending_.keys_pressed.push_back(key);
  in->pending_.key_mods.push_back(mods);
}

void Input::on_button(GLFWwindow* w, int button, int action, int mods) {
  Input* in = self(w);
  if (!in) return;
  if (action == GLFW_PRESS) {
    if (button == GLFW_MOUSE_BUTTON_LEFT) in->drag_ = (mods & GLFW_MOD_SHIFT) ? DragMode::pan : DragMode::orbit;
    else if (button == GLFW_MOUSE_BUTTON_MIDDLE) in->drag_ = DragMode::pan;
    // The drag starts where the event stream says the cursor is: querying the pointer now
    // would see where it is after every queued event (synthetic input arrives in bursts).
    if (!in->have_cursor_) {
      double x = 0, y = 0;
      glfwGetCursorPos(w, &x, &y);
      in->last_cursor_ = to_pixels(w, x, y);
      in->have_cursor_ = true;
    }
    if (button == GLFW_MOUSE_BUTTON_RIGHT) in->pending_.picks.push_back(in->last_cursor_);
  } else if (action == GLFW_RELEASE) {
    if (button == GLFW_MOUSE_BUTTON_LEFT || button == GLFW_MOUSE_BUTTON_MIDDLE) in->drag_ = DragMode::none;
  }
}

void Input::on_cursor(GLFWwindow* w, double x, double y) {
  Input* in = self(w);
  if (!in) return;
  const glm::dvec2 p = to_pixels(w, x, y);
  if (in->have_cursor_) {
    const glm::dvec2 d = p - in->last_cursor_;
    if (in->drag_ == DragMode::orbit) in->pending_.orbit_delta += d;
    if (in->drag_ == DragMode::pan) in->pending_.pan_delta += d;
  }
  in->last_cursor_ = p;
  in->have_cursor_ = true;
}

void Input::on_scroll(GLFWwindow* w, double, double dy) {
  if (Input* in = self(w)) in->pending_.wheel += dy;
}

void Input::on_resize(GLFWwindow* w, int, int) {
  if (Input* in = self(w)) in->pending_.resized = true;
}

}  // namespace mds::viewer
