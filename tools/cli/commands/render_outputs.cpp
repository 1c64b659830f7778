#include "cli/commands/render_outputs.h"

#include <algorithm>
#include <cstdio>
#include <cstring>

#include "util/atomic_file.h"
#include "util/errors.h"
#include "util/median.h"

namespace rayfold::core::commands {

nlohmann::json camera_json(const rayfold::Camera& camera) {
  const rayfold::Intrinsics k = camera.intrinsics();
  const rayfold::Vec3 eye = camera.eye();
  const bool ortho = camera.is_orthographic();
  const rayfold::Matrix4 m = camera.camera_to_world();
  return {{"width", camera.width()},
          {"height", camera.height()},
          {"eye", {eye[0], eye[1], eye[2]}},
          {"camera_to_world", std::vector<double>(m.begin(), m.end())},
          {"convention", "opengl: +x right, +y up, looking down -z; row-major"},
          {"projection", ortho ? "orthographic" : "perspective"},
          {"intrinsics", {{"fx", k.fx}, {"fy", k.fy}, {"cx", k.cx}, {"cy", k.cy}}},
          {"intrinsics_units", ortho ? "pixels per world unit; cx, cy pixels" : "pixels"},
          {"pixel_centres", "at (x + 0.5, y + 0.5) from the top-left corner, y down"},
          {"vfov_degrees", camera.vfov_degrees()}};
}

void write_ids(const std::string& path, const RenderArgs& args, const rayfold::Scene& scene) {
  const std::vector<std::string> names = scene.instance_names();
  const std::vector<int> nodes = scene.instance_nodes();
  const std::vector<std::string> mesh_names = scene.mesh_names();
  nlohmann::json instances = nlohmann::json::array();
  for (uint32_t i = 0; i < names.size(); ++i) {
    const uint32_t mesh = scene.instance_mesh(i);
    // The node index too: many real files repeat names.
    instances.push_back(
        {{"id", i}, {"name", names[i]}, {"node", nodes[i]}, {"mesh", mesh}, {"mesh_name", mesh_names[mesh]}});
  }
  const nlohmann::json j = {{"scene", args.scene},
                            {"miss", rayfold::kMiss},
                            {"note", "InstanceID indexes instances; PrimitiveID is the triangle within the mesh"},
                            {"instances", instances}};
  write_text_file(path, j.dump(2) + "\n");
}

void write_stats(const std::string& path, const RenderArgs& args, const rayfold::Scene& scene,
                 const rayfold::Camera& camera, const rayfold::Renderer& renderer, const rayfold::GBuffer& g,
                 const rayfold::StageTimes& times, size_t frames, double load_ms, std::optional<PassInfo> pass) {
  const rayfold::RendererOptions& o = args.options;
  const rayfold::BuildStats built = renderer.build_stats();
  nlohmann::json j;
  j["rayfold_version"] = RAYFOLD_VERSION_STRING;
  j["scene"] = args.scene;
  j["width"] = camera.width();
  j["height"] = camera.height();
  if (pass)
    j["pass"] = {{"index", pass->index},
                 {"views", pass->views},
                 {"note", "times_ms are the whole pass's: its views were traced together"}};
  j["backend"] = o.backend == rayfold::Backend::opencl ? "opencl" : "cpu";
  j["device"] = renderer.device_name();
  j["kernel"] = g.kernel;
  j["kernel_reason"] = g.kernel_reason;
  j["frames"] = frames;
  j["instances"] = scene.instance_count();
  j["meshes"] = scene.mesh_count();
  j["triangles"] = scene.triangle_count();
  j["rays"] = g.rays;
  j["fold"] = fold_name(g.fold);
  j["fold_requested"] = fold_name(args.fold);
  j["camera"] = camera_json(camera);
  j["options"] = {{"cull", o.cull},
                  {"animate", args.animate},
                  {"braid", o.braid},
                  {"threads", o.threads},
                  {"precision", o.fast_math ? "fast" : "exact"}};
  const size_t pixels = static_cast<size_t>(g.width) * g.height;
  j["pixels"] = {{"hit", g.hits}, {"miss", pixels - g.hits}};
  j["instances_after_culling"] = g.top_level.traced_instances;
  j["instances_out_of_range"] = g.top_level.out_of_range;
  // The loader's, then the render's (a mesh's missing attribute is in both: once).
  std::vector<std::string> warnings = scene.warnings();
  append_unsaid(warnings, g.warnings);
  j["warnings"] = warnings;
  j["times_ms"] = {{"load", load_ms},           {"blas_build", built.trees_ms},
                   {"cull", times.cull_ms},     {"tlas_build", times.tlas_ms},
                   {"upload", times.upload_ms}, {"ray_list", times.ray_list_ms},
                   {"trace", times.trace_ms},   {"readback", times.readback_ms}};
  j["sah_cost"] = {{"blas", built.sah_cost}, {"tlas", g.top_level.sah_cost}};
  nlohmann::json buffers = nlohmann::json::object();
  size_t total = 0;
  for (const auto& [name, bytes] : renderer.device_buffers()) {
    buffers[name] = bytes;
    total += bytes;
  }
  j["device_buffer_bytes"] = buffers;
  j["device_bytes_total"] = total;
  write_text_file(path, j.dump(2) + "\n");
}

rayfold::StageTimes median_stages(const std::vector<rayfold::StageTimes>& frames) {
  auto of = [&](double rayfold::StageTimes::*stage) {
    std::vector<double> v;
    for (const rayfold::StageTimes& t : frames) v.push_back(t.*stage);
    return median(v);
  };
  using S = rayfold::StageTimes;
  return {of(&S::cull_ms),     of(&S::tlas_ms),  of(&S::upload_ms),
          of(&S::ray_list_ms), of(&S::trace_ms), of(&S::readback_ms)};
}

void print_comparison(const rayfold::GBuffer& none, const rayfold::StageTimes& none_times,
                      const rayfold::GBuffer& folded, const rayfold::StageTimes& folded_times) {
  auto total = [](const rayfold::StageTimes& t) { return t.ray_list_ms + t.trace_ms + t.readback_ms; };
  auto update = [](const rayfold::StageTimes& t) { return t.cull_ms + t.tlas_ms + t.upload_ms; };
  const double pixels = static_cast<double>(none.width) * none.height;
  const size_t differ = rayfold::count_differing_pixels(none, folded);
  const std::string folded_name = std::string("folded ") + fold_name(folded.fold);
  std::printf("\n  %-28s %14s %14s\n", "", "unfolded", folded_name.c_str());
  std::printf("  %-28s %14s %14s\n", "rays traced", with_commas(none.rays).c_str(), with_commas(folded.rays).c_str());
  std::printf("  %-28s %14zu %14zu\n", "instances in the TLAS", none.top_level.traced_instances,
              folded.top_level.traced_instances);
  std::printf("  %-28s %14.2f %14.2f\n", "update ms (cull+TLAS+upload)", update(none_times), update(folded_times));
  std::printf("  %-28s %14.2f %14.2f\n", "trace ms", none_times.trace_ms, folded_times.trace_ms);
  std::printf("  %-28s %14.2f %14.2f\n", "T ms (rays+trace+readback)", total(none_times), total(folded_times));
  std::printf("  %-28s %14.2f %14.2f\n", "Mpixels/s (T)", pixels / (total(none_times) * 1e3),
              pixels / (total(folded_times) * 1e3));
  std::printf("  %-28s %14s %13.2fx\n", "speed-up (T)", "", total(none_times) / total(folded_times));
  if (differ == 0)
    std::printf("  %-28s %29s\n", "hit info", "identical (every channel, every pixel)");
  else
    std::printf("  %-28s %22zu pixels DIFFER\n", "hit info", differ);
}

std::string frame_name(const std::string& option, const std::string& name, int frame, bool* has_field) {
  std::string out;
  bool field = false;
  for (size_t i = 0; i < name.size(); ++i) {
    if (name[i] != '%') {
      out += name[i];
      continue;
    }
    size_t j = i + 1;
    while (j < name.size() && std::isdigit(static_cast<unsigned char>(name[j]))) ++j;
    if (j >= name.size() || name[j] != 'd' || field || j - i > 3)
      throw UsageError(option + ": '" + name + "' may hold one frame field such as %04d, and no other %");
    char buf[32];
    std::snprintf(buf, sizeof buf, ("%" + name.substr(i + 1, j - i - 1) + "d").c_str(), frame);
    out += buf;
    field = true;
    i = j;
  }
  if (has_field) *has_field = field;
  return out;
}

std::vector<std::string> named_view_files(const std::string& option, const std::string& name,
                                          const std::vector<std::optional<std::string>>& view_names) {
  try {
    return rayfold::view_files(name, view_names);
  } catch (const rayfold::InputError& e) {
    throw UsageError(option + ": " + e.what());
  }
}

// The output name of one view: for a camera list, the view's index in a
// frame field (%04d) or its name in %s (view_file_stem: a transforms.json's
// file_path, a COLMAP image's name; a rayfold camera list's views are named
// by index), one of the two required when it has several views;
// "-left"/"-right" before the extension for a stereo pair.
std::string view_output(const std::string& option, const std::string& name, const std::string& label,
                        const std::string& view_name, bool stereo, size_t views) {
  if (name.empty()) return name;
  if (stereo) {
    if (name.find('%') != std::string::npos)
      throw UsageError(option + ": '" + name + "': a stereo pair is named NAME-left and NAME-right, without a field");
    const size_t dot = name.rfind('.');
    return name.substr(0, dot) + "-" + label + name.substr(dot);
  }
  if (name.find("%s") != std::string::npos) return named_view_files(option, name, {view_name})[0];
  bool field = false;
  const std::string out = frame_name(option, name, std::stoi(label), &field);
  if (!field && views > 1)
    throw UsageError(option + ": '" + name + "' needs a view field such as %04d (the view's index) or %s (its name) for " +
                     std::to_string(views) + " views");
  return out;
}

}  // namespace rayfold::core::commands
