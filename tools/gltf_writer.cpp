#include "gltf_writer.h"

#include <cstring>

#include <tiny_gltf.h>
#include <glm/geometric.hpp>
#include <glm/gtc/quaternion.hpp>

#include "util/atomic_file.h"
#include "util/errors.h"

namespace rayfold::core {
namespace {

// Appends bytes to the single buffer, 4-byte aligned as glTF requires, and
// returns the new buffer view's index.
int add_view(tinygltf::Model& m, const void* data, size_t bytes, int target) {
  std::vector<unsigned char>& buf = m.buffers[0].data;
  while (buf.size() % 4) buf.push_back(0);
  tinygltf::BufferView v;
  v.buffer = 0;
  v.byteOffset = buf.size();
  v.byteLength = bytes;
  v.target = target;
  buf.insert(buf.end(), static_cast<const unsigned char*>(data), static_cast<const unsigned char*>(data) + bytes);
  m.bufferViews.push_back(v);
  return static_cast<int>(m.bufferViews.size()) - 1;
}

}  // namespace

void write_glb(const Scene& scene, const std::string& path) {
  tinygltf::Model model;
  model.asset.version = "2.0";
  model.asset.generator = "rayfold";
  model.buffers.resize(1);
  for (const Mesh& mesh : scene.meshes) {
    tinygltf::Accessor pos;
    pos.bufferView = add_view(model, mesh.positions.data(), mesh.positions.size() * 12, TINYGLTF_TARGET_ARRAY_BUFFER);
    pos.componentType = TINYGLTF_COMPONENT_TYPE_FLOAT;
    pos.type = TINYGLTF_TYPE_VEC3;
    pos.count = mesh.positions.size();
    glm::vec3 lo(INFINITY), hi(-INFINITY);
    for (const glm::vec3& p : mesh.positions) {
      lo = glm::min(lo, p);
      hi = glm::max(hi, p);
    }
    pos.minValues = {lo.x, lo.y, lo.z};
    pos.maxValues = {hi.x, hi.y, hi.z};
    model.accessors.push_back(pos);

    // The smallest index type that fits keeps the bundled scene small.
    tinygltf::Accessor idx;
    idx.type = TINYGLTF_TYPE_SCALAR;
    idx.count = mesh.indices.size();
    if (mesh.positions.size() <= 65536) {
      std::vector<uint16_t> small(mesh.indices.begin(), mesh.indices.end());
      idx.bufferView = add_view(model, small.data(), small.size() * 2, TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER);
      idx.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT;
    } else {
      idx.bufferView =
          add_view(model, mesh.indices.data(), mesh.indices.size() * 4, TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER);
      idx.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT;
    }
    model.accessors.push_back(idx);

    tinygltf::Primitive prim;
    prim.attributes["POSITION"] = static_cast<int>(model.accessors.size()) - 2;
    prim.indices = static_cast<int>(model.accessors.size()) - 1;
    prim.mode = TINYGLTF_MODE_TRIANGLES;
    tinygltf::Mesh gm;
    gm.name = mesh.name;
    gm.primitives.push_back(prim);
    model.meshes.push_back(gm);
  }

  tinygltf::Scene gscene;
  for (const Instance& inst : scene.instances) {
    tinygltf::Node node;
    node.mesh = static_cast<int>(inst.mesh);
    node.name = inst.name;
    if (inst.world_from_object != Xform(1.0)) {
      const double* m = &inst.world_from_object[0][0];
      node.matrix.assign(m, m + 16);
    }
    model.nodes.push_back(node);
    gscene.nodes.push_back(static_cast<int>(model.nodes.size()) - 1);
  }
  if (scene.camera) {
    const CameraSpec& c = *scene.camera;
    tinygltf::Camera cam;
    cam.type = "perspective";
    cam.perspective.yfov = c.vfov_degrees * M_PI / 180.0;
    cam.perspective.znear = 0.01;
    model.cameras.push_back(cam);
    // The node's -z looks at look_at, its +y is up.
    const glm::dvec3 w = glm::normalize(c.eye - c.look_at);
    const glm::dvec3 u = glm::normalize(glm::cross(c.up, w));
    const glm::dvec3 v = glm::cross(w, u);
    const Xform m(glm::dvec4(u, 0.0), glm::dvec4(v, 0.0), glm::dvec4(w, 0.0), glm::dvec4(c.eye, 1.0));
    tinygltf::Node node;
    node.camera = 0;
    node.name = "camera";
    node.matrix.assign(&m[0][0], &m[0][0] + 16);
    model.nodes.push_back(node);
    gscene.nodes.push_back(static_cast<int>(model.nodes.size()) - 1);
  }
  model.scenes.push_back(gscene);
  model.defaultScene = 0;

  AtomicFile file(path);
  tinygltf::TinyGLTF writer;
  if (!writer.WriteGltfSceneToFile(&model, file.temp_path(), false, true, false, true))
    throw RuntimeFailure(path + ": cannot write the glTF file");
  file.commit();
}

}  // namespace rayfold::core
