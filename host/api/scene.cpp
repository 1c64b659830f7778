#include "rayfold/scene.h"

#include <cmath>
#include <fstream>
#include <sstream>

#include "api/convert.h"
#include "api/resolve_gbuffer.h"
#include "api/scene_state.h"
#include "bvh/scene_file.h"
#include "pipeline/auto_frame.h"
#include "pipeline/pipeline.h"
#include "rayfold/errors.h"
#include "rayfold/version.h"
#include "scene/camera.h"
#include "scene/gltf_loader.h"
#include "util/atomic_file.h"

namespace rayfold {
namespace detail {

void check_affine(const Matrix4& m, const std::string& what) {
  for (double v : m)
    if (!std::isfinite(v)) throw InputError("", what + " is not finite");
  if (m[12] != 0.0 || m[13] != 0.0 || m[14] != 0.0 || m[15] != 1.0)
    throw InputError("", what + " is not affine: its last row must be 0 0 0 1");
}

std::shared_ptr<const core::SceneData> current_trees(SceneState& s) {
  if (!s.trees || s.trees_version != s.structure_version || s.trees_clock != s.clock) {
    s.trees = std::make_shared<const core::SceneData>(core::prepare_scene(s.scene, 0, {}, s.merge()));
    s.trees_version = s.structure_version;
    s.trees_clock = s.clock;
  }
  return s.trees;
}

void at_pose(SceneState& s, double seconds, const char* caller, const std::function<void()>& body) {
  core::Scene saved = s.scene;
  const double saved_time = s.time;
  const std::vector<uint64_t> saved_moved = s.moved_at;
  const unsigned saved_attributes = s.file ? s.file->attributes() : 0u;
  auto put_back = [&] {
    // Attributes a render read for the first time while posed are kept:
    // the scene put back gets them too, posed at its own time. Should that
    // read fail, the file forgets them (the next render that asks reads
    // them again) and the scene is put back all the same.
    if (s.file && s.file->attributes() != saved_attributes) try {
        auto [posed, said] = pose_file(*s.file, saved_time);
        adopt_attributes(saved, std::move(posed), s.file->attributes());
        s.warnings.insert(s.warnings.end(), said.begin(), said.end());
      } catch (...) {
        s.file->set_attributes(saved_attributes);
      }
    std::vector<uint32_t> moved;
    s.time = saved_time;
    if (core::apply_pose(s.scene, std::move(saved), &moved)) {
      s.structure_version++;
      s.moved_at = saved_moved;
      return;
    }
    for (uint32_t i : moved) s.moved_at[i] = ++s.clock;
  };
  try {
    pose_at(s, seconds, caller);
    body();
  } catch (...) {
    put_back();
    throw;
  }
  put_back();
}

}  // namespace detail
namespace {

void check_instance(const detail::SceneState& s, uint32_t instance) {
  if (instance >= s.scene.instances.size())
    throw InputError(s.path, "instance " + std::to_string(instance) + " does not exist (the scene has " +
                                 std::to_string(s.scene.instances.size()) + ")");
}

void check_mesh(const detail::SceneState& s, uint32_t mesh) {
  if (mesh >= s.scene.meshes.size())
    throw InputError(s.path, "mesh " + std::to_string(mesh) + " does not exist (the scene has " +
                                 std::to_string(s.scene.meshes.size()) + ")");
}

}  // namespace

Scene::Scene() : state_(std::make_shared<detail::SceneState>()) {}

Scene Scene::load(const std::string& path, const LoadOptions& options) {
  {
    std::ifstream in(path, std::ios::binary);
    char head[16] = {};
    if (in && in.read(head, sizeof(head)) && core::is_scene_file(head, sizeof(head))) {
      const LoadOptions defaults;
      if (options.scene != defaults.scene || options.camera != defaults.camera || !std::isnan(options.time) ||
          options.label_key != defaults.label_key)
        throw InputError(path, "is a rayfold scene file: it holds one posed scene, so scene, camera and time "
                               "options do not apply (set them when saving it from the glTF file)");
      std::ostringstream bytes;
      in.seekg(0);
      bytes << in.rdbuf();
      if (!in && !in.eof()) throw InputError(path, "cannot be read");
      return from_bytes(bytes.str(), path);
    }
  }
  Scene s;
  core::LoadOptions lo;
  lo.scene = options.scene;
  lo.camera = options.camera;
  lo.time = options.time;
  lo.threads = options.threads;
  lo.attributes = detail::attributes_for(options.channels);
  lo.label_key = options.label_key;
  s.state_->time = options.time;
  s.state_->file = std::make_shared<core::GltfFile>(path, lo);
  s.state_->scene = s.state_->file->scene_at(options.time);
  s.state_->warnings = s.state_->file->warnings();
  s.state_->path = path;
  s.state_->moved_at.assign(s.state_->scene.instances.size(), 0);
  return s;
}

std::string Scene::to_bytes() const {
  detail::SceneState& s = *state_;
  const core::SceneData& trees = *detail::current_trees(s);
  core::SceneFile file{s.scene, trees, s.path, s.warnings};
  return core::scene_file_bytes(file, RAYFOLD_VERSION_STRING);
}

Scene Scene::from_bytes(const std::string& bytes, const std::string& what) {
  return from_bytes(bytes.data(), bytes.size(), what);
}

Scene Scene::from_bytes(const char* bytes, size_t size, const std::string& what) {
  core::SceneFile file = core::read_scene_file(bytes, size, what, RAYFOLD_VERSION_STRING);
  Scene s;
  detail::SceneState& st = *s.state_;
  st.scene = std::move(file.scene);
  st.path = std::move(file.source);
  st.warnings = std::move(file.warnings);
  st.moved_at.assign(st.scene.instances.size(), 0);
  st.trees = std::make_shared<const core::SceneData>(std::move(file.data));
  return s;
}

void Scene::save(const std::string& path) const { core::write_text_file(path, to_bytes()); }

uint32_t Scene::add_mesh(const float* positions, size_t vertex_count, const uint32_t* indices, size_t index_count,
                         const std::string& name) {
  if (index_count % 3 != 0)
    throw InputError(
        "", "mesh '" + name + "': " + std::to_string(index_count) + " indices is not a whole number of triangles");
  core::Mesh mesh;
  mesh.name = name;
  mesh.positions.resize(vertex_count);
  for (size_t v = 0; v < vertex_count; ++v) {
    for (int k = 0; k < 3; ++k)
      if (!std::isfinite(positions[3 * v + k]))
        throw InputError("", "mesh '" + name + "': position " + std::to_string(v) + " is not finite");
    mesh.positions[v] = glm::vec3(positions[3 * v], positions[3 * v + 1], positions[3 * v + 2]);
  }
  mesh.indices.assign(indices, indices + index_count);
  for (size_t i = 0; i < index_count; ++i)
    if (indices[i] >= vertex_count) {
      std::ostringstream s;
      s << "mesh '" << name << "': index " << i << " is " << indices[i] << ", but the mesh has " << vertex_count
        << " vertices";
      throw InputError("", s.str());
    }
  state_->scene.meshes.push_back(std::move(mesh));
  state_->structure_version++;
  return static_cast<uint32_t>(state_->scene.meshes.size() - 1);
}

uint32_t Scene::add_mesh(const std::vector<float>& positions, const std::vector<uint32_t>& indices,
                         const std::string& name) {
  if (positions.size() % 3 != 0)
    throw InputError("", "mesh '" + name + "': " + std::to_string(positions.size()) +
                             " position values is not a whole number of x, y, z vertices");
  return add_mesh(positions.data(), positions.size() / 3, indices.data(), indices.size(), name);
}

uint32_t Scene::add_instance(uint32_t mesh, const Matrix4& world_from_object, const std::string& name) {
  check_mesh(*state_, mesh);
  detail::check_affine(world_from_object, "instance '" + name + "': world_from_object");
  core::Instance inst;
  inst.mesh = mesh;
  inst.world_from_object = detail::to_xform(world_from_object);
  inst.name = name.empty() ? "instance " + std::to_string(state_->scene.instances.size()) : name;
  state_->scene.instances.push_back(inst);
  state_->moved_at.push_back(0);
  state_->structure_version++;
  return static_cast<uint32_t>(state_->scene.instances.size() - 1);
}

void Scene::set_transform(uint32_t instance, const Matrix4& world_from_object) {
  check_instance(*state_, instance);
  core::Instance& inst = state_->scene.instances[instance];
  detail::check_affine(world_from_object, "instance '" + inst.name + "': world_from_object");
  const core::Aabb b = state_->scene.mesh_bounds(inst.mesh);
  const core::Xform m = detail::to_xform(world_from_object);
  if (!b.empty())
    for (int corner = 0; corner < 8; ++corner) {
      const glm::dvec3 p((corner & 1 ? b.hi : b.lo).x, (corner & 2 ? b.hi : b.lo).y, (corner & 4 ? b.hi : b.lo).z);
      const glm::dvec3 w = core::transform_point(m, p);
      for (int k = 0; k < 3; ++k)
        if (!(std::fabs(w[k]) <= core::kMaxWorldCoordinate))
          throw InputError(state_->path,
                           "instance '" + inst.name + "' would reach beyond world coordinates of +-8.5e37 (2^126)");
    }
  inst.world_from_object = m;
  state_->moved_at[instance] = ++state_->clock;
}

void Scene::set_time(double seconds) { detail::pose_at(*state_, seconds, "set_time"); }

namespace detail {

std::pair<core::Scene, std::vector<std::string>> pose_file(core::GltfFile& file, double time) {
  const size_t said = file.warnings().size();
  core::Scene posed = file.scene_at(time);
  return {std::move(posed),
          std::vector<std::string>(file.warnings().begin() + static_cast<std::ptrdiff_t>(said), file.warnings().end())};
}

void pose_at(SceneState& s, double seconds, const char* caller) {
  if (!s.file)
    throw InputError("", std::string(caller) + ": the scene was not loaded from a file, so it has no animations");
  std::vector<uint32_t> moved;
  auto [posed, said] = pose_file(*s.file, seconds);
  s.warnings.insert(s.warnings.end(), said.begin(), said.end());  // a node scaled to zero now
  s.time = seconds;
  if (core::apply_pose(s.scene, std::move(posed), &moved)) {
    s.moved_at.assign(s.scene.instances.size(), 0);
    s.structure_version++;
    return;
  }
  for (uint32_t i : moved) s.moved_at[i] = ++s.clock;
}

}  // namespace detail

double Scene::time() const { return state_->time; }
bool Scene::animated() const { return state_->file && state_->file->animated(); }
double Scene::animation_end() const { return state_->file ? state_->file->animation_end() : 0.0; }

Matrix4 Scene::transform(uint32_t instance) const {
  check_instance(*state_, instance);
  return detail::to_matrix(state_->scene.instances[instance].world_from_object);
}

size_t Scene::mesh_count() const { return state_->scene.meshes.size(); }
size_t Scene::instance_count() const { return state_->scene.instances.size(); }
size_t Scene::triangle_count() const { return state_->scene.triangle_count(); }
size_t Scene::stored_triangle_count() const { return state_->scene.unique_triangle_count(); }

uint32_t Scene::instance_mesh(uint32_t instance) const {
  check_instance(*state_, instance);
  return state_->scene.instances[instance].mesh;
}

std::vector<float> Scene::mesh_positions(uint32_t mesh) const {
  check_mesh(*state_, mesh);
  std::vector<float> out;
  out.reserve(3 * state_->scene.meshes[mesh].positions.size());
  for (const glm::vec3& p : state_->scene.meshes[mesh].positions) out.insert(out.end(), {p.x, p.y, p.z});
  return out;
}

std::vector<uint32_t> Scene::mesh_indices(uint32_t mesh) const {
  check_mesh(*state_, mesh);
  return state_->scene.meshes[mesh].indices;
}

std::vector<std::string> Scene::instance_names() const {
  std::vector<std::string> names;
  names.reserve(state_->scene.instances.size());
  for (const core::Instance& i : state_->scene.instances) names.push_back(i.name);
  return names;
}

std::vector<int> Scene::instance_nodes() const {
  std::vector<int> nodes;
  nodes.reserve(state_->scene.instances.size());
  for (const core::Instance& i : state_->scene.instances) nodes.push_back(i.node);
  return nodes;
}

std::vector<std::string> Scene::mesh_names() const {
  std::vector<std::string> names;
  names.reserve(state_->scene.meshes.size());
  for (const core::Mesh& m : state_->scene.meshes) names.push_back(m.name);
  return names;
}

std::vector<std::string> Scene::labels() const {
  detail::load_attributes(*state_, kLabel);
  return state_->scene.labels.empty() ? std::vector<std::string>{""} : state_->scene.labels;
}

const std::string& Scene::path() const { return state_->path; }
const std::vector<std::string>& Scene::warnings() const { return state_->warnings; }

std::vector<std::string> Scene::camera_names() const {
  std::vector<std::string> names;
  for (const core::Scene::FileCamera& c : state_->scene.cameras) names.push_back(c.name);
  return names;
}

namespace {

View view_of(const core::CameraSpec& spec) {
  View v;
  v.eye = {spec.eye.x, spec.eye.y, spec.eye.z};
  v.target = {spec.look_at.x, spec.look_at.y, spec.look_at.z};
  v.up = {spec.up.x, spec.up.y, spec.up.z};
  v.vfov_degrees = spec.vfov_degrees;
  v.orthographic = spec.orthographic;
  v.half_height = spec.ymag;
  return v;
}

}  // namespace

std::vector<Scene::FileCamera> Scene::file_cameras() const {
  std::vector<FileCamera> out;
  for (const core::Scene::FileCamera& c : state_->scene.cameras) out.push_back({c.name, c.node, view_of(c.spec)});
  return out;
}

std::vector<std::string> Scene::scene_names() const { return state_->scene.scene_names; }
int Scene::scene_index() const { return state_->scene.scene_index; }

View Scene::default_view(ViewSource* source) const {
  detail::SceneState& state = *state_;
  const core::Scene& s = state.scene;
  if (!s.camera) {
    const std::shared_ptr<const core::SceneData> trees = detail::current_trees(state);
    if (state.framed_on != trees) {
      core::PipelineOptions cpu_options;
      cpu_options.backend = Backend::cpu;
      core::Pipeline cpu(s, cpu_options, trees);
      const core::AutoFrame framed = core::auto_frame(s, cpu);
      state.framed = framed.spec;
      state.framed_interior = framed.kind == core::ViewKind::interior;
      state.framed_on = trees;
    }
  }
  if (source)
    *source = s.camera ? ViewSource::file_camera : state.framed_interior ? ViewSource::interior : ViewSource::object;
  return view_of(s.camera ? *s.camera : state.framed);
}

bool Scene::has_camera() const { return state_->scene.camera.has_value(); }

Camera Scene::default_camera(int width, int height) const { return Camera::from_view(default_view(), width, height); }

std::array<double, 6> Scene::bounds() const {
  const core::Aabb b = state_->scene.world_bounds();
  if (b.empty()) return {0, 0, 0, 0, 0, 0};
  return {b.lo.x, b.lo.y, b.lo.z, b.hi.x, b.hi.y, b.hi.z};
}

}  // namespace rayfold
