// loom-view [SCENE] [--set PATH=VALUE ...] [--frames N --screenshot FILE.png]
// Interactive viewer (GLFW + Dear ImGui, OpenGL 2.1): play/pause/step, solver and substeps (applied by
// restarting), on/off toggles for the scene's effects and sliders for each cloth's material (applied live
// by rebuilding, LiveScene.h), per-stage timings of the last frame, colliders at their current poses,
// orbit camera (left-drag), zoom (wheel), drag a cloth vertex (right-drag). Scenes with Bullet rigid
// `bodies` run in a Bullet world (bullet::BulletScene): the bodies are drawn as colliders and picking goes
// through BulletCloth::ray_test. Drawing is the offscreen
// renderer's (render/src/gl/Draw.cpp). With --frames N --screenshot FILE it plays N frames, saves
// the window to FILE and exits (the Xvfb test uses this).
#include <GLFW/glfw3.h>
#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_opengl2.h>
#include <imgui.h>
#include <stb_image_write.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "LiveScene.h"
#include "gl/ColliderShapes.h"
#include "gl/Draw.h"
#include "loom/cloth/Error.h"
#include "loom/cloth/OutputFile.h"
#include "loom/cloth/Solver.h"
#include "loom/scene/Scene.h"

namespace {

using namespace loom;
using cloth::Vec3;

// The ray from the camera through window point (mx, my) (screen coordinates, y down): unit direction.
Vec3 pick_ray(const render::Camera& cam, double aspect, double mx, double my, int win_w, int win_h) {
  const Vec3 f = (cam.target - cam.eye).normalized();
  const Vec3 s = f.cross(Vec3(0, 1, 0)).normalized(), u = s.cross(f);
  const double tan_y = std::tan(0.5 * cam.fov_deg * render::gl::kPi / 180.0);
  const double nx = 2.0 * mx / win_w - 1.0, ny = 1.0 - 2.0 * my / win_h;
  return (f + nx * tan_y * aspect * s + ny * tan_y * u).normalized();
}

// One slider on a log scale for a positive material value; true when changed.
bool log_slider(const char* label, double& value, double lo, double hi) {
  float v = static_cast<float>(value);
  if (!ImGui::SliderFloat(label, &v, static_cast<float>(lo), static_cast<float>(hi), "%.3g",
                          ImGuiSliderFlags_Logarithmic))
    return false;
  value = v;
  return true;
}

std::vector<render::RenderMesh> meshes_of(const cloth::Simulation& sim) {
  static const Vec3 kColors[] = {
      {0.80, 0.22, 0.18}, {0.20, 0.42, 0.75}, {0.90, 0.68, 0.20}, {0.30, 0.62, 0.35}};
  std::vector<render::RenderMesh> out;
  for (size_t i = 0; i < sim.cloths().size(); ++i) {
    render::RenderMesh m;
    m.triangles = sim.cloths()[i]->mesh().triangles();
    for (const auto& f : sim.cloths()[i]->mesh().triangle_frames()) m.corner_uv.push_back(f.rest_uv);
    m.color = kColors[i % 4];
    out.push_back(std::move(m));
  }
  return out;
}

struct Options {
  std::string scene;
  std::vector<std::string> sets;
  int frames = -1;
  std::string screenshot;
};

// An OpenGL 2.1 window with Dear ImGui on it; `vsync` off for screenshot runs.
GLFWwindow* open_window(const std::string& title, bool vsync) {
  if (!glfwInit()) throw Error("", "loom-view", "cannot initialise GLFW (no display? try xvfb-run)");
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 2);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 1);
  GLFWwindow* win = glfwCreateWindow(960, 720, title.c_str(), nullptr, nullptr);
  if (!win) throw Error("", "loom-view", "cannot open an OpenGL 2.1 window");
  glfwMakeContextCurrent(win);
  glfwSwapInterval(vsync ? 1 : 0);
  ImGui::CreateContext();
  ImGui::GetIO().IniFilename = nullptr;
  ImGui_ImplGlfw_InitForOpenGL(win, true);
  ImGui_ImplOpenGL2_Init();
  return win;
}

void close_window(GLFWwindow* win) {
  ImGui_ImplOpenGL2_Shutdown();
  ImGui_ImplGlfw_Shutdown();
  ImGui::DestroyContext();
  glfwDestroyWindow(win);
  glfwTerminate();
}

// What the view is framed on, from the start state: the cloths extended downwards by their size (cloth falls
// and hangs) and the colliders.
struct Framing {
  Vec3 center = Vec3::Zero();
  double size = 0.0;    // m, diagonal of the cloths' start bounds
  double ground = 0.0;  // m, height of the ground plane
  render::Camera cam0;  // the automatic camera of the framed bounds
};

Framing frame_start_state(const viewer::LiveScene& live) {
  Framing f;
  render::Bounds b;
  for (const auto& c : live.sim().cloths())
    for (const Vec3& p : c->state().x) b.add(p);
  f.size = (b.hi - b.lo).norm();
  b.add(Vec3(b.lo.x(), b.lo.y() - 0.8 * f.size, b.lo.z()));
  render::gl::add_collider_bounds(b, live.colliders());
  f.ground = render::gl::ground_plane(live.colliders()).value_or(render::ground_height(b));
  f.center = 0.5 * (b.lo + b.hi);
  f.cam0 = render::auto_camera(b, 960.0 / 720.0);
  return f;
}

// The orbit camera: yaw and pitch (rad) about the framed centre at distance `dist` (m).
struct Orbit {
  double yaw = 0.0, pitch = 0.4, dist = 1.0;
  render::Camera camera(const Framing& f) const {
    render::Camera cam;
    cam.target = f.center;
    cam.eye = f.center +
              dist * Vec3(std::sin(yaw) * std::cos(pitch), std::sin(pitch), std::cos(yaw) * std::cos(pitch));
    cam.fov_deg = f.cam0.fov_deg;
    return cam;
  }
};

// The panel's state across frames.
struct Panel {
  std::vector<std::string> solvers;  // cloth::solver_names()
  int solver = 0;                    // index into `solvers`
  int substeps = 1;
  std::string error;  // the last rejected edit, shown until the next one
  bool playing = false, step = false;
  cloth::FrameStats last;  // the last frame's timings and figures
};

// On/off toggles for the effects the scene names; true when one changed (the run is rebuilt).
bool effect_toggles(viewer::LiveScene& live) {
  bool rebuild = false;
  viewer::Effects& on = live.enabled();
  const viewer::Effects& has = live.available();
  if (has.drag || has.strain_limit || has.tethers || has.colliders || has.self_collision || has.character) {
    ImGui::Separator();
    ImGui::Text("effects");
    if (has.drag) rebuild |= ImGui::Checkbox("drag / wind", &on.drag);
    if (has.strain_limit) rebuild |= ImGui::Checkbox("strain limit", &on.strain_limit);
    if (has.tethers) rebuild |= ImGui::Checkbox("tethers", &on.tethers);
    if (has.colliders) rebuild |= ImGui::Checkbox("colliders (body collision)", &on.colliders);
    if (has.self_collision) rebuild |= ImGui::Checkbox("self collision", &on.self_collision);
    if (has.character) rebuild |= ImGui::Checkbox("character", &on.character);
  }
  return rebuild;
}

// Material sliders per cloth; true when one changed (the run is rebuilt).
bool material_sliders(viewer::LiveScene& live) {
  bool rebuild = false;
  for (size_t c = 0; c < live.materials().size(); ++c) {
    cloth::Material& m = live.materials()[c];
    ImGui::PushID(static_cast<int>(c));
    if (ImGui::CollapsingHeader(("material: " + live.sim().cloths()[c]->name()).c_str())) {
      double stretch = 0.5 * (m.stretch_weft + m.stretch_warp), bend = 0.5 * (m.bend_weft + m.bend_warp);
      if (log_slider("stretch N/m", stretch, 10.0, 1e6)) {  // keeps the weft/warp ratio
        const double k = stretch / (0.5 * (m.stretch_weft + m.stretch_warp));
        m.stretch_weft *= k, m.stretch_warp *= k, rebuild = true;
      }
      rebuild |= log_slider("shear N/m", m.shear, 1.0, 1e5);
      if (log_slider("bend N m", bend, 1e-8, 1e-2)) {
        const double k = bend / (0.5 * (m.bend_weft + m.bend_warp));
        m.bend_weft *= k, m.bend_warp *= k, rebuild = true;
      }
      rebuild |= log_slider("damping s", m.damping, 1e-7, 1e-2);
      rebuild |= log_slider("density kg/m2", m.areal_density, 0.01, 2.0);
    }
    ImGui::PopID();
  }
  return rebuild;
}

// The control panel: play/pause/step/restart, solver and substeps, effects, materials, the last frame's
// per-stage timings. Applies edits: a restart starts the run again, a rebuild keeps time and states; a
// rejected edit is shown in the panel and keeps the old run.
void control_panel(const scene::Scene& sc, viewer::LiveScene& live, Panel& ui) {
  ImGui::SetNextWindowPos(ImVec2(10, 10), ImGuiCond_Once);
  ImGui::Begin("loom", nullptr, ImGuiWindowFlags_AlwaysAutoResize);
  ImGui::Text("%s  t = %.3f s  frame %d", sc.name.c_str(), live.time(), live.frame());
  if (live.bullet()) ImGui::Text("Bullet world: %zu rigid bodies (edits restart the run)", sc.bodies.size());
  if (ImGui::Button(ui.playing ? "pause" : "play")) ui.playing = !ui.playing;
  ImGui::SameLine();
  if (ImGui::Button("step")) ui.step = true;
  ImGui::SameLine();
  bool restart = ImGui::Button("restart");
  std::vector<const char*> names;
  for (const auto& s : ui.solvers) names.push_back(s.c_str());
  restart |= ImGui::Combo("solver", &ui.solver, names.data(), static_cast<int>(names.size()));
  restart |= ImGui::SliderInt("substeps", &ui.substeps, 1, 400);
  ImGui::Text("time step %.3g ms", 1e3 * sc.setup.frame_dt / ui.substeps);
  // Effects the scene names, on/off; materials per cloth. Both rebuild the run in place.
  bool rebuild = effect_toggles(live);
  rebuild |= material_sliders(live);
  if (!ui.error.empty()) ImGui::TextColored(ImVec4(1, 0.4f, 0.3f, 1), "%s", ui.error.c_str());
  ImGui::Separator();
  ImGui::Text("last frame: %.3f ms", ui.last.total_ms);
  const std::vector<std::string> stages = live.sim().stage_names();
  for (size_t i = 0; i < stages.size() && i < ui.last.stage_ms.size(); ++i)
    ImGui::Text("  %-18s %8.3f ms", stages[i].c_str(), ui.last.stage_ms[i]);
  ImGui::Text("kinetic %.4g J  max strain %.3g", ui.last.kinetic, ui.last.max_strain);
  ImGui::End();
  if (restart || rebuild) {
    live.solver() = ui.solvers[ui.solver];
    live.substeps() = ui.substeps;
    try {
      restart ? live.restart() : live.rebuild();
      if (restart) ui.last = cloth::FrameStats{};
      ui.error.clear();
    } catch (const std::exception& e) {
      ui.error = e.what();
      std::cerr << "loom-view: " << e.what() << "\n";
    }
  }
}

// The mouse between frames (window coordinates, y down).
struct Mouse {
  double last_x = 0.0, last_y = 0.0;
  bool right_was_down = false;
};

// Orbit (left-drag) and zoom (wheel) when ImGui does not want the mouse; right button: drag a cloth vertex,
// held at its picked depth along the mouse ray from `cam`.
void handle_mouse(GLFWwindow* win, viewer::LiveScene& live, const render::Camera& cam, double aspect,
                  Orbit& orbit, Mouse& mouse) {
  int ww, wh;
  glfwGetWindowSize(win, &ww, &wh);
  double mx, my;
  glfwGetCursorPos(win, &mx, &my);
  const bool right = glfwGetMouseButton(win, GLFW_MOUSE_BUTTON_RIGHT) == GLFW_PRESS;
  if (!right && live.grabbed()) live.release();
  if (right && ww > 0 && wh > 0) {
    const Vec3 ray = pick_ray(cam, aspect, mx, my, ww, wh);
    if (!live.grabbed() && !ImGui::GetIO().WantCaptureMouse && !mouse.right_was_down) live.grab(cam.eye, ray);
    if (live.grabbed()) live.drag_to(cam.eye + live.grabbed()->distance * ray);
  }
  mouse.right_was_down = right;
  if (!ImGui::GetIO().WantCaptureMouse) {
    if (glfwGetMouseButton(win, GLFW_MOUSE_BUTTON_LEFT) == GLFW_PRESS) {
      orbit.yaw -= 0.01 * (mx - mouse.last_x);
      orbit.pitch = std::min(1.5, std::max(-0.2, orbit.pitch + 0.01 * (my - mouse.last_y)));
    }
    orbit.dist *= std::pow(0.9, ImGui::GetIO().MouseWheel);
  }
  mouse.last_x = mx;
  mouse.last_y = my;
}

// The back buffer (w x h) as a PNG.
void save_screenshot(const std::string& file, int w, int h) {
  std::vector<unsigned char> rgb(size_t(w) * h * 3);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadBuffer(GL_BACK);
  glReadPixels(0, 0, w, h, GL_RGB, GL_UNSIGNED_BYTE, rgb.data());
  stbi_flip_vertically_on_write(1);
  std::string png;
  const auto append = [](void* context, void* data, int size) {
    static_cast<std::string*>(context)->append(static_cast<const char*>(data), static_cast<size_t>(size));
  };
  if (!stbi_write_png_to_func(append, &png, w, h, 3, rgb.data(), 3 * w))
    throw Error(file, "", "cannot encode PNG");
  OutputFile out(file);  // never through a link or into a FIFO at the path
  out << png;
  out.close();
  if (!out) throw Error(file, "", "write failed");
}

int run(const Options& o) {
  scene::Scene sc = scene::load_scene(o.scene, o.sets);
  // A scene with Bullet rigid `bodies` runs in a Bullet world (LiveScene.h); its colliders are the bodies.
  viewer::LiveScene live(sc);
  GLFWwindow* win = open_window("loom-view: " + sc.name, o.frames < 0);

  std::vector<render::RenderMesh> meshes = meshes_of(live.sim());
  const render::gl::Textures tex = render::gl::create_textures();
  const Framing frame = frame_start_state(live);
  render::gl::ColliderShapes collider_shapes;
  Orbit orbit;
  orbit.yaw = std::atan2(frame.cam0.eye.x() - frame.center.x(), frame.cam0.eye.z() - frame.center.z());
  orbit.dist = (frame.cam0.eye - frame.center).norm();

  Panel ui;
  ui.solvers = cloth::solver_names();
  for (size_t i = 0; i < ui.solvers.size(); ++i)
    if (ui.solvers[i] == sc.setup.solver.method) ui.solver = static_cast<int>(i);
  ui.substeps = sc.setup.substeps;
  ui.playing = o.frames >= 0;
  int played = 0;
  Mouse mouse;

  while (!glfwWindowShouldClose(win)) {
    glfwPollEvents();
    ImGui_ImplOpenGL2_NewFrame();
    ImGui_ImplGlfw_NewFrame();
    ImGui::NewFrame();
    control_panel(sc, live, ui);

    int w, h;
    glfwGetFramebufferSize(win, &w, &h);
    const render::Camera cam = orbit.camera(frame);
    const double aspect = h > 0 ? double(w) / h : 1.0;
    handle_mouse(win, live, cam, aspect, orbit, mouse);

    if (ui.playing || ui.step) {
      ui.last = live.step_frame();
      ++played;
      ui.step = false;
      if (!ui.last.finite) ui.playing = false;
    }

    render::gl::DrawParams p;
    p.camera = cam;
    p.aspect = aspect;
    p.ground = frame.ground;
    p.extent = frame.size;
    p.center = frame.center;
    p.viewport_w = w;
    p.viewport_h = h;
    std::vector<const cloth::Vec3s*> x;
    for (const auto& c : live.sim().cloths()) x.push_back(&c->state().x);
    collider_shapes.update(live.colliders(), 6.0 * frame.size);
    glClear(GL_STENCIL_BUFFER_BIT);
    render::gl::draw_scene(p, tex, meshes, x, collider_shapes.posed(live.colliders()));
    ImGui::Render();
    ImGui_ImplOpenGL2_RenderDrawData(ImGui::GetDrawData());

    if (o.frames >= 0 && played >= o.frames) {
      save_screenshot(o.screenshot, w, h);
      std::printf("loom-view: %d frames, screenshot %s (%dx%d)\n", played, o.screenshot.c_str(), w, h);
      break;
    }
    glfwSwapBuffers(win);
  }
  close_window(win);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if ((a == "--frames" || a == "--screenshot" || a == "--set") && i + 1 >= argc) {
      std::fprintf(stderr, "loom-view: error: %s needs a value\n", a.c_str());
      return 2;
    }
    if (a == "-h" || a == "--help") {
      std::printf("Usage: loom-view [SCENE] [--set PATH=VALUE ...] [--frames N --screenshot FILE.png]\n");
      return 0;
    } else if (a == "--frames") {
      o.frames = std::atoi(argv[++i]);
    } else if (a == "--screenshot") {
      o.screenshot = argv[++i];
    } else if (a == "--set") {
      o.sets.push_back(argv[++i]);
    } else {
      o.scene = a;
    }
  }
  if (o.scene.empty()) o.scene = std::string(LOOM_SOURCE_DIR) + "/scenes/hanging_cloth.json";
  if ((o.frames >= 0) != !o.screenshot.empty()) {
    std::fprintf(stderr, "loom-view: error: --frames and --screenshot go together\n");
    return 2;
  }
  try {
    return run(o);
  } catch (const std::exception& e) {
    std::cerr << "loom-view: error: " << e.what() << "\n";
    return 1;
  }
}
