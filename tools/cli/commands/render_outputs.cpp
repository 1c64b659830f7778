#include "cli/commands/render_outputs.h"

#include <cstdio>

#include "reference/hit_compare.h"
#include "scene/dataset_cameras.h"
#include "util/atomic_file.h"
#include "util/errors.h"

#ifndef RAYFOLD_VERSION
#define RAYFOLD_VERSION "unknown"
#endif

namespace rayfold::core::commands {

ExrMetadata exr_metadata(const Camera& camera, const Scene& scene, const RenderArgs& args) {
  return view_metadata(camera, scene, args.scene, fold_name(args.frame.fold), args.frame.planar_depth,
                       args.frame.exact_depth, RAYFOLD_VERSION);
}

nlohmann::json camera_json(const Camera& camera) {
  const Intrinsics k = intrinsics(camera);
  nlohmann::json m = nlohmann::json::array();
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) m.push_back(camera.world_from_camera[c][r]);
  const glm::dvec3 eye(camera.world_from_camera[3]);
  return {{"width", camera.width},
          {"height", camera.height},
          {"eye", {eye.x, eye.y, eye.z}},
          {"camera_to_world", m},
          {"convention", "opengl: +x right, +y up, looking down -z; row-major"},
          {"projection", is_orthographic(camera) ? "orthographic" : "perspective"},
          {"intrinsics", {{"fx", k.fx}, {"fy", k.fy}, {"cx", k.cx}, {"cy", k.cy}}},
          {"intrinsics_units", is_orthographic(camera) ? "pixels per world unit; cx, cy pixels" : "pixels"},
          {"pixel_centres", "at (x + 0.5, y + 0.5) from the top-left corner, y down"},
          {"vfov_degrees", camera.vfov_degrees}};
}

void write_ids(const std::string& path, const RenderArgs& args, const Scene& scene) {
  nlohmann::json instances = nlohmann::json::array();
  for (size_t i = 0; i < scene.instances.size(); ++i) {
    const Instance& inst = scene.instances[i];
    // The node index too: many real files repeat names.
    instances.push_back({{"id", i},
                         {"name", inst.name},
                         {"node", inst.node},
                         {"mesh", inst.mesh},
                         {"mesh_name", scene.meshes[inst.mesh].name}});
  }
  const nlohmann::json j = {{"scene", args.scene},
                            {"miss", RF_INVALID},
                            {"note", "InstanceID indexes instances; PrimitiveID is the triangle within the mesh"},
                            {"instances", instances}};
  write_text_file(path, j.dump(2) + "\n");
}

void write_stats(const std::string& path, const RenderArgs& args, const Scene& scene, const Camera& camera,
                 const Pipeline& renderer, const RenderResult& result, double load_ms, std::optional<PassInfo> pass) {
  nlohmann::json j;
  j["rayfold_version"] = RAYFOLD_VERSION;
  j["scene"] = args.scene;
  j["width"] = camera.width;
  j["height"] = camera.height;
  if (pass)
    j["pass"] = {{"index", pass->index},
                 {"views", pass->views},
                 {"note", "times_ms are the whole pass's: its views were traced together"}};
  j["backend"] = args.renderer.backend == Backend::opencl ? "opencl" : "cpu";
  j["device"] = renderer.device_name();
  j["kernel"] = result.kernel;
  j["kernel_reason"] = result.kernel_reason;
  j["frames"] = result.frames.size();
  j["instances"] = scene.instances.size();
  j["meshes"] = scene.meshes.size();
  j["triangles"] = scene.triangle_count();
  j["rays"] = result.rays;
  j["fold"] = fold_name(result.fold);
  j["fold_requested"] = fold_name(args.frame.fold);
  j["camera"] = camera_json(camera);
  j["options"] = {{"cull", args.frame.cull},
                  {"animate", args.frame.animate_frame >= 0},
                  {"braid", args.renderer.braid.enabled ? args.renderer.braid.items_per_instance : 0},
                  {"threads", args.renderer.threads},
                  {"precision", args.renderer.precision == KernelPrecision::exact ? "exact" : "fast"}};
  size_t hit = 0;
  for (const rf_pixel_hit& h : result.hits) hit += h.instance != RF_INVALID;
  j["pixels"] = {{"hit", hit}, {"miss", result.hits.size() - hit}};
  j["instances_after_culling"] = result.frame_stats.kept;
  j["instances_out_of_range"] = result.views.empty() ? 0 : result.views[0].out_of_range;
  j["warnings"] = args.load_warnings;  // the loader's, then the trace's
  for (const std::string& w : result.warnings) j["warnings"].push_back(w);
  j["times_ms"] = {{"load", load_ms},
                   {"blas_build", renderer.blas_build_ms()},
                   {"cull", result.median.cull_ms},
                   {"tlas_build", result.median.tlas_ms},
                   {"upload", result.median.upload_ms},
                   {"ray_list", result.median.ray_list_ms},
                   {"trace", result.median.trace_ms},
                   {"readback", result.median.readback_ms}};
  j["sah_cost"] = {{"blas", renderer.scene_data().blas.sah_cost}, {"tlas", result.frame_stats.tlas_sah}};
  nlohmann::json buffers = nlohmann::json::object();
  size_t total = 0;
  for (const BufferInfo& b : renderer.device_buffers()) {
    buffers[b.name] = b.bytes;
    total += b.bytes;
  }
  j["device_buffer_bytes"] = buffers;
  j["device_bytes_total"] = total;
  write_text_file(path, j.dump(2) + "\n");
}

void print_comparison(const RenderResult& none, const RenderResult& folded, Fold fold) {
  auto total = [](const FrameTimes& t) { return t.ray_list_ms + t.trace_ms + t.readback_ms; };
  const double pixels = static_cast<double>(none.hits.size());
  const size_t differ = count_differing_pixels(none.hits, folded.hits);
  const std::string folded_name = std::string("folded ") + fold_name(fold);
  std::printf("\n  %-28s %14s %14s\n", "", "unfolded", folded_name.c_str());
  std::printf("  %-28s %14s %14s\n", "rays traced", with_commas(none.rays).c_str(), with_commas(folded.rays).c_str());
  std::printf("  %-28s %14zu %14zu\n", "instances in the TLAS", none.instances, folded.instances);
  std::printf("  %-28s %14.2f %14.2f\n", "update ms (cull+TLAS+upload)",
              none.median.cull_ms + none.median.tlas_ms + none.median.upload_ms,
              folded.median.cull_ms + folded.median.tlas_ms + folded.median.upload_ms);
  std::printf("  %-28s %14.2f %14.2f\n", "trace ms", none.median.trace_ms, folded.median.trace_ms);
  std::printf("  %-28s %14.2f %14.2f\n", "T ms (rays+trace+readback)", total(none.median), total(folded.median));
  std::printf("  %-28s %14.2f %14.2f\n", "Mpixels/s (T)", pixels / (total(none.median) * 1e3),
              pixels / (total(folded.median) * 1e3));
  std::printf("  %-28s %14s %13.2fx\n", "speed-up (T)", "", total(none.median) / total(folded.median));
  if (differ == 0)
    std::printf("  %-28s %29s\n", "hit info", "identical (8 channels, every pixel)");
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

// The output name of one view: for a camera list, the view's index in a
// frame field (%04d) or its name in %s (view_file_stem: a transforms.json's
// file_path, a COLMAP image's name; a rayfold camera list's views are named
// by index), one of the two required when it has several views;
// "-left"/"-right" before the extension for a stereo pair.
std::string view_output(const std::string& option, const std::string& name, const cli::View& v, bool stereo,
                        size_t views) {
  if (name.empty()) return name;
  if (stereo) {
    if (name.find('%') != std::string::npos)
      throw UsageError(option + ": '" + name + "': a stereo pair is named NAME-left and NAME-right, without a field");
    const size_t dot = name.rfind('.');
    return name.substr(0, dot) + "-" + v.label + name.substr(dot);
  }
  const size_t named = name.find("%s");
  if (named != std::string::npos) {
    if (name.find('%', named + 2) != std::string::npos || name.find('%') != named)
      throw UsageError(option + ": '" + name + "' may hold one field, %s (the view's name) or %04d (its index)");
    const std::string stem = view_file_stem(v.name);
    if (stem.empty())
      throw UsageError(option + ": view " + v.label + "'s name '" + v.name +
                       "' leaves no file name for %s; name the views by index (%04d)");
    return name.substr(0, named) + stem + name.substr(named + 2);
  }
  bool field = false;
  const std::string out = frame_name(option, name, std::stoi(v.label), &field);
  if (!field && views > 1)
    throw UsageError(option + ": '" + name + "' needs a view field such as %04d (the view's index) or %s (its name) for " +
                     std::to_string(views) + " views");
  return out;
}

}  // namespace rayfold::core::commands
