// The Python module rayfold._core: the public C++ API (rayfold/rayfold.h)
// with numpy arrays in and out. Arrays out own their C++ buffers (no copy);
// renders release the GIL; one render of a scene runs at a time.
#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>
#include <nanobind/stl/array.h>
#include <nanobind/stl/filesystem.h>
#include <nanobind/stl/optional.h>
#include <nanobind/stl/pair.h>
#include <nanobind/stl/shared_ptr.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/tuple.h>
#include <nanobind/stl/vector.h>
#include <deque>

#include <pthread.h>

#include <cmath>
#include <map>
#include <memory>
#include <mutex>
#include <sstream>

#include "api/resolve_gbuffer.h"
#include "output/channels.h"
#include "plane_pool.h"
#include "rayfold/rayfold.h"
#include "scene/dataset_cameras.h"

namespace nb = nanobind;
using namespace nb::literals;

namespace {

template <class T>
using InArray = nb::ndarray<const T, nb::c_contig, nb::device::cpu>;

std::string shape_text(size_t ndim, const size_t* shape) {
  std::ostringstream s;
  s << "(";
  for (size_t i = 0; i < ndim; ++i) s << (i ? ", " : "") << shape[i];
  s << (ndim == 1 ? ",)" : ")");
  return s.str();
}

// Any array-like as a contiguous numpy array of dtype; an InputError naming
// `what` when numpy cannot make one.
template <class T>
InArray<T> as_array(nb::handle obj, const char* dtype, const std::string& what) {
  nb::object np = nb::module_::import_("numpy");
  nb::object arr;
  try {
    arr = np.attr("ascontiguousarray")(obj, "dtype"_a = dtype);
  } catch (nb::python_error&) {
    throw rayfold::InputError("", what + " is not an array of numbers");
  }
  return nb::cast<InArray<T>>(arr);
}

rayfold::Matrix4 as_matrix4(nb::handle obj, const std::string& what) {
  const InArray<double> a = as_array<double>(obj, "float64", what);
  std::vector<size_t> shape(a.ndim());
  for (size_t i = 0; i < a.ndim(); ++i) shape[i] = a.shape(i);
  if (a.ndim() != 2 || a.shape(0) != 4 || a.shape(1) != 4)
    throw rayfold::InputError("",
                              what + " must be a 4x4 matrix, not of shape " + shape_text(shape.size(), shape.data()));
  rayfold::Matrix4 m;
  for (int i = 0; i < 16; ++i) m[i] = a.data()[i];
  return m;
}

rayfold::Vec3 as_vec3(nb::handle obj, const std::string& what) {
  const InArray<double> a = as_array<double>(obj, "float64", what);
  if (a.size() != 3) throw rayfold::InputError("", what + " must have 3 numbers, not " + std::to_string(a.size()));
  return {a.data()[0], a.data()[1], a.data()[2]};
}

// A numpy array that owns the vector's buffer: moved, not copied.
template <class T>
nb::object to_numpy(std::vector<T>&& v, std::initializer_list<size_t> shape) {
  auto* heap = new std::vector<T>(std::move(v));
  nb::capsule owner(heap, [](void* p) noexcept { delete static_cast<std::vector<T>*>(p); });
  return nb::cast(nb::ndarray<nb::numpy, T>(heap->data(), shape, owner));
}

// Never destroyed: numpy arrays may outlive the module's statics at exit.
rayfold::python::PlanePool& plane_pool() {
  static auto* pool = [] {
    auto* p = new rayfold::python::PlanePool;
    pthread_atfork(nullptr, nullptr, [] { plane_pool().reset_lock_after_fork(); });
    return p;
  }();
  return *pool;
}

// A G-buffer plane as a numpy array that owns it and, when numpy lets it
// go, hands its memory to plane_pool() for the next render.
template <class T>
nb::object plane_to_numpy(std::vector<T>&& v, const std::vector<size_t>& shape) {
  auto* heap = new std::vector<T>(std::move(v));
  nb::capsule owner(heap, [](void* p) noexcept {
    auto* v = static_cast<std::vector<T>*>(p);
    plane_pool().give(std::move(*v));
    delete v;
  });
  return nb::cast(nb::ndarray<nb::numpy, T>(heap->data(), shape.size(), shape.data(), owner));
}

// A camera's per-pixel vector (ray_direction, ray_origin) as (H, W, 3).
nb::object per_pixel(const rayfold::Camera& c, rayfold::Vec3 (rayfold::Camera::*f)(int, int) const) {
  const size_t w = c.width(), h = c.height();
  std::vector<double> out(3 * w * h);
  for (size_t y = 0; y < h; ++y)
    for (size_t x = 0; x < w; ++x) {
      const rayfold::Vec3 r = (c.*f)(static_cast<int>(x), static_cast<int>(y));
      std::copy(r.begin(), r.end(), out.begin() + 3 * (y * w + x));
    }
  return to_numpy(std::move(out), {h, w, 3});
}

nb::object matrix_to_numpy(const rayfold::Matrix4& m) {
  return to_numpy(std::vector<double>(m.begin(), m.end()), {4, 4});
}

rayfold::Fold parse_fold(const std::string& s) {
  if (s == "none") return rayfold::Fold::none;
  if (s == "y") return rayfold::Fold::y;
  if (s == "x") return rayfold::Fold::x;
  if (s == "xy" || s == "yx") return rayfold::Fold::xy;
  throw rayfold::InputError("",
                            "fold must be 'none', 'y', 'x', 'xy' or, to render, 'auto' (the cost model's choice), "
                            "not '" +
                                s + "'");
}

using rayfold::fold_name;

rayfold::CameraConvention parse_convention(const std::string& s) {
  if (s == "opencv" || s == "colmap") return rayfold::CameraConvention::opencv;
  if (s == "opengl" || s == "blender" || s == "nerf") return rayfold::CameraConvention::opengl;
  throw rayfold::InputError("",
                            "convention must be 'opencv' (+z forward, +y down; also 'colmap') or 'opengl' "
                            "(-z forward, +y up; also 'blender', 'nerf'), not '" +
                                s + "'");
}

// channels=: None for all, or the plane names as a list or one
// comma-separated string (output/channels.h).
unsigned parse_channels(nb::handle channels) {
  if (channels.is_none()) return rayfold::kAllChannels;
  if (nb::isinstance<nb::str>(channels)) return rayfold::core::parse_channels(nb::cast<std::string>(channels));
  std::string list;
  for (nb::handle item : channels) {
    if (!nb::isinstance<nb::str>(item)) throw rayfold::InputError("", "channels: each name must be a str");
    list += (list.empty() ? "" : ",") + nb::cast<std::string>(item);
  }
  return rayfold::core::parse_channels(list);
}

rayfold::RendererOptions renderer_options(const std::string& backend, const std::string& device,
                                          const std::string& kernel, unsigned threads,
                                          const std::string& depth = "distance", bool exact_depth = false) {
  rayfold::RendererOptions o;
  o.exact_depth = exact_depth;
  if (backend == "opencl")
    o.backend = rayfold::Backend::opencl;
  else if (backend == "cpu")
    o.backend = rayfold::Backend::cpu;
  else
    throw rayfold::InputError("", "backend must be 'opencl' or 'cpu', not '" + backend + "'");
  if (kernel == "auto")
    o.kernel = rayfold::Kernel::automatic;
  else if (kernel == "tile")
    o.kernel = rayfold::Kernel::tile;
  else if (kernel == "single")
    o.kernel = rayfold::Kernel::single;
  else if (kernel == "measure")
    o.kernel = rayfold::Kernel::measure;
  else
    throw rayfold::InputError("", "kernel must be 'auto', 'tile', 'single' or 'measure', not '" + kernel + "'");
  if (depth == "distance")
    o.depth = rayfold::Depth::distance;
  else if (depth == "planar")
    o.depth = rayfold::Depth::planar;
  else
    throw rayfold::InputError("", "depth must be 'distance' (along the ray) or 'planar' (along the camera's axis), "
                                  "not '" + depth + "'");
  o.device = device;
  o.threads = threads;
  return o;
}

// The G-buffer as Python sees it: numpy planes and the camera it was
// rendered with.
struct PyGBuffer {
  // One per plane of output/channels.h, in its order; None where not asked for.
  std::vector<nb::object> planes;
  int width = 0, height = 0;
  std::string fold;
  size_t rays = 0, hits = 0;
  double trace_ms = 0.0, frame_ms = 0.0;
  std::vector<std::string> warnings;
  rayfold::Camera camera;
  int views_in_trace = 1;
  rayfold::Depth depth_kind = rayfold::Depth::distance;
  bool exact_depth = false;
  rayfold::StageTimes stages;
  rayfold::TopLevelStats top_level;
  std::string kernel, kernel_reason;
  double time = NAN;  // GBuffer::time
};

PyGBuffer to_python(rayfold::GBuffer&& g, const rayfold::Camera& camera) {
  const size_t h = g.height, w = g.width;
  PyGBuffer p{{},
              g.width,
              g.height,
              fold_name(g.fold),
              g.rays,
              g.hits,
              g.trace_ms,
              g.frame_ms,
              std::move(g.warnings),
              camera,
              g.views_in_trace,
              g.depth_kind,
              g.exact_depth,
              g.stages,
              g.top_level,
              std::move(g.kernel),
              std::move(g.kernel_reason),
              g.time};
  // A plane not asked for (channels=) is None; (H, W) or (H, W, components).
  for (const rayfold::core::PlaneSpec& spec : rayfold::core::plane_specs()) {
    if (!(g.channels & spec.bit)) {
      p.planes.push_back(nb::none());
      continue;
    }
    const std::initializer_list<size_t> flat = {h, w}, deep = {h, w, size_t(spec.components)};
    const auto shape = spec.components == 1 ? flat : deep;
    p.planes.push_back(spec.floats ? plane_to_numpy(std::move(g.*spec.floats), shape)
                                   : plane_to_numpy(std::move(g.*spec.ids), shape));
  }
  return p;
}

// A plane of a GBuffer back as a flat vector (None: empty, not asked for).
template <class T>
std::vector<T> plane_values(const nb::object& plane, const char* dtype, const char* what) {
  if (plane.is_none()) return {};
  const InArray<T> a = as_array<T>(plane, dtype, what);
  return std::vector<T>(a.data(), a.data() + a.size());
}

// The public G-buffer of a Python one, for write_exr.
rayfold::GBuffer from_python(const PyGBuffer& p) {
  rayfold::GBuffer g;
  g.width = p.width;
  g.height = p.height;
  g.channels = 0;
  const std::vector<rayfold::core::PlaneSpec>& specs = rayfold::core::plane_specs();
  for (size_t k = 0; k < specs.size(); ++k) {
    const rayfold::core::PlaneSpec& spec = specs[k];
    if (p.planes.at(k).is_none()) continue;
    g.channels |= spec.bit;
    if (spec.floats)
      g.*spec.floats = plane_values<float>(p.planes[k], "float32", spec.name);
    else
      g.*spec.ids = plane_values<uint32_t>(p.planes[k], "uint32", spec.name);
  }
  g.fold = p.fold == "y" ? rayfold::Fold::y : p.fold == "x" ? rayfold::Fold::x : p.fold == "xy" ? rayfold::Fold::xy
                                                                                                 : rayfold::Fold::none;
  g.depth_kind = p.depth_kind;
  g.exact_depth = p.exact_depth;
  g.time = p.time;
  return g;
}

// The planes as properties, one per plane of output/channels.h (its name,
// and an older one where it has one), documented by the table in
// docs/channels.md.
template <class Class>
void add_plane_properties(Class& cls) {
  static const char* const kDocs[] = {
      "(H, W) float32: distance from the eye along the pixel's ray (or planar, depth_kind); inf on a miss",
      "(H, W, 3) float32: world-space unit geometric normal, front by the triangle's winding; 0 on a miss",
      "(H, W, 2) float32: barycentric weights (u, v) of the triangle's 2nd and 3rd vertex (not texture "
      "coordinates: texcoord); 0 on a miss",
      "(H, W) uint32: index into Scene.instance_names; MISS",
      "(H, W) uint32: triangle index within the mesh; MISS",
      "(H, W, 3) float32: world-space unit shading normal, the file's NORMAL interpolated (the geometric normal "
      "where the triangle has none); 0 on a miss",
      "(H, W, 2) float32: TEXCOORD_0 interpolated, as the file gives it ((0, 0) where the mesh has none); 0 on a "
      "miss",
      "(H, W, 2) float32: TEXCOORD_1 likewise",
      "(H, W, 3) float32: world-space position of the hit (the triangle's point at the barycentrics); 0 on a miss",
      "(H, W, 3) float32: the hit in the mesh's own (object) space; 0 on a miss",
      "(H, W) uint32: the glTF material index; DEFAULT_MATERIAL where the primitive names none; MISS",
      "(H, W, 4) float32: linear RGBA base colour, baseColorFactor * COLOR_0 * baseColorTexture sampled at the "
      "pixel's ray-cone level of detail; 0 on a miss",
      "(H, W, 2) float32: metallic and roughness, factors times the metallicRoughnessTexture's B and G; 0 on a "
      "miss",
      "(H, W, 3) float32: linear RGB emission, emissiveFactor * emissiveTexture * emissive strength; 0 on a miss",
      "(H, W) uint32: index into Scene.labels (0: no label) from the instance's node extras; MISS",
      "(H, W, 2) float32: optical flow to flow_to's view: where the pixel's surface point lands there, minus "
      "the pixel, in pixels (+x right, +y down); NaN behind the other eye; 0 on a miss",
      "(H, W) uint32: 1 where the surface point is seen in flow_to's view (inside its image, unoccluded), else "
      "0; MISS on a miss",
      "(H, W, 4) float32: world-space unit tangent orthogonal to shading_normal (the file's TANGENT, else "
      "MikkTSpace's from the normal texture's coordinates), then the bitangent sign w: bitangent = w * "
      "cross(shading_normal, tangent); 0 on a miss",
      "(H, W, 3) float32: world-space unit shading normal with the material's normalTexture applied in the "
      "tangent frame (shading_normal where there is none); 0 on a miss",
  };
  const std::vector<rayfold::core::PlaneSpec>& specs = rayfold::core::plane_specs();
  RF_CHECK_EQ(specs.size(), sizeof(kDocs) / sizeof(kDocs[0]), "a doc per plane");
  static std::deque<std::string> alias_docs;  // nanobind keeps the pointer
  for (size_t k = 0; k < specs.size(); ++k) {
    cls.def_prop_ro(
        specs[k].name, [k](const PyGBuffer& g) { return g.planes.at(k); }, kDocs[k]);
    if (specs[k].alias && std::string(specs[k].alias) != "t") {
      alias_docs.push_back(std::string("the older name of ") + specs[k].name + ", kept: " + kDocs[k]);
      cls.def_prop_ro(
          specs[k].alias, [k](const PyGBuffer& g) { return g.planes.at(k); }, alias_docs.back().c_str());
    }
  }
}

// A scene and what renders it: renderers by options, reused across calls;
// a mutex so that a render (which drops the GIL) never overlaps a change.
// fold="auto" and align="auto": the choice the cost model predicts fastest
// (Renderer::choose_fastest) for views of one size and intrinsics, made on
// the first render of such views and kept for the later ones: its probe
// costs tens of ms, more than a frame.
class AutoPlans {
 public:
  // The fold and views per pass for these cameras: as asked, or as chosen.
  // align -1 is "auto".
  std::pair<rayfold::Fold, int> plan(rayfold::Renderer& r, const std::vector<rayfold::Camera>& cameras,
                                     const std::string& fold, int align) {
    const bool fold_auto = fold == "auto";
    if (cameras.empty() || (!fold_auto && align >= 0))
      return {fold_auto ? rayfold::Fold::none : parse_fold(fold), align};
    const rayfold::Camera& c = cameras[0];
    const rayfold::Intrinsics k = c.intrinsics();
    char key[256];
    std::snprintf(key, sizeof key, "%s|%d|%d|%d|%a|%a|%a|%a|%d|%d", fold.c_str(), align, c.width(), c.height(), k.fx,
                  k.fy, k.cx, k.cy, int(c.is_orthographic()), int(cameras.size() > 1));
    auto it = chosen_.find(key);
    if (it == chosen_.end()) {
      std::vector<rayfold::Fold> folds;
      if (!fold_auto) folds = {parse_fold(fold)};
      std::vector<int> aligns;
      if (align > 0) aligns = {align};
      if (align == 0) aligns = {rayfold::kMaxAlignedViews};
      it = chosen_.emplace(key, r.choose_fastest(cameras, folds, aligns)).first;
    }
    return {it->second.fold, align < 0 ? it->second.align : align};
  }

 private:
  std::map<std::string, rayfold::AutoChoice> chosen_;
};

struct PyScene {
  rayfold::Scene scene;
  std::mutex mutex;
  std::map<std::string, std::unique_ptr<rayfold::Renderer>> renderers;
  std::map<std::string, AutoPlans> plans;  // by renderers' key
};

struct PyRenderer {
  std::shared_ptr<PyScene> scene;
  std::unique_ptr<rayfold::Renderer> renderer;
  AutoPlans plans;
};

// render_views' align: a count (0: as many as a pass holds) or "auto" (-1).
int parse_align(nb::handle align) {
  if (nb::isinstance<nb::str>(align)) {
    const std::string a = nb::cast<std::string>(align);
    if (a == "auto") return -1;
    if (a == "all") return 0;
    throw rayfold::InputError("", "align must be a count of views, 'all' or 'auto', not '" + a + "'");
  }
  if (nb::isinstance<bool>(align) || !nb::isinstance<int>(align))
    throw rayfold::InputError(
        "", "align must be a count of views, 'all' or 'auto', not a " + std::string(nb::inst_name(align).c_str()));
  const int n = nb::cast<int>(align);
  if (n < 0)
    throw rayfold::InputError("",
                              "align must be a count of views (0: as many as a pass holds), 'all' or 'auto', "
                              "not " +
                                  std::to_string(n));
  return n;
}

template <class F>
auto locked(PyScene& s, F&& f) {
  nb::gil_scoped_release release;
  std::lock_guard<std::mutex> lock(s.mutex);
  return f();
}

// Planes for n pixels or rays from plane_pool(), where it has them: the
// channels' planes of a GBuffer (depth) or RayHits (t).
void take_planes(size_t n, unsigned channels, std::vector<float>& depth, std::vector<float>& normal,
                 std::vector<float>& uv, std::vector<uint32_t>& instance_id, std::vector<uint32_t>& primitive_id) {
  rayfold::python::PlanePool& pool = plane_pool();
  if (channels & rayfold::kDepth) depth = pool.take<float>(n);
  if (channels & rayfold::kNormal) normal = pool.take<float>(3 * n);
  if (channels & rayfold::kUv) uv = pool.take<float>(2 * n);
  if (channels & rayfold::kInstanceId) instance_id = pool.take<uint32_t>(n);
  if (channels & rayfold::kPrimitiveId) primitive_id = pool.take<uint32_t>(n);
}

// The planes a render of `asked` fills: those asked for and those the
// trace makes for the resolved ones (api/resolve_gbuffer.h). Asked of the
// renderer as such, they come from plane_pool() and keep_asked gives the
// extra ones back, instead of being allocated and freed every render.
unsigned planes_for(unsigned asked) { return asked | rayfold::detail::trace_channels(asked); }

void take_planes(rayfold::GBuffer& g, const rayfold::Camera& camera, unsigned channels) {
  const size_t n = static_cast<size_t>(camera.width()) * camera.height();
  rayfold::python::PlanePool& pool = plane_pool();
  for (const rayfold::core::PlaneSpec& spec : rayfold::core::plane_specs()) {
    if (!(channels & spec.bit)) continue;
    if (spec.floats)
      g.*spec.floats = pool.take<float>(spec.components * n);
    else
      g.*spec.ids = pool.take<uint32_t>(spec.components * n);
  }
}

// The planes of g that `asked` left out back to the pool; g then holds what was asked.
void keep_asked(rayfold::GBuffer& g, unsigned asked) {
  rayfold::python::PlanePool& pool = plane_pool();
  for (const rayfold::core::PlaneSpec& spec : rayfold::core::plane_specs()) {
    if (asked & spec.bit) continue;
    if (spec.floats)
      pool.give(std::move(g.*spec.floats));
    else
      pool.give(std::move(g.*spec.ids));
  }
  g.channels &= asked;
}

// Renders with the renderer `pick` returns (called under the scene's lock).
// fold: a fold's name or "auto" (plans' choice).
template <class Pick>
PyGBuffer render_locked(PyScene& s, Pick&& pick, const rayfold::Camera& camera, const std::string& fold,
                        unsigned channels, AutoPlans& plans, const std::optional<rayfold::FlowTo>& flow_to = {},
                        std::optional<double> time = {}) {
  if (fold != "auto") parse_fold(fold);  // a bad name refused before the planes are taken
  rayfold::GBuffer g;
  take_planes(g, camera, planes_for(channels));
  locked(s, [&] {
    rayfold::Renderer& r = pick();
    const rayfold::Fold f = plans.plan(r, {camera}, fold, 1).first;
    // time: this render's pose alone (Renderer::render_at).
    const rayfold::FlowTo* to = flow_to ? &*flow_to : nullptr;
    if (time)
      r.render_into_at(g, *time, camera, f, planes_for(channels), to);
    else if (to)
      r.render_into(g, camera, f, planes_for(channels), *to);
    else
      r.render_into(g, camera, f, planes_for(channels));
  });
  keep_asked(g, channels);
  return to_python(std::move(g), camera);
}

// A query's rays as float32 arrays of shape (..., 3), both alike; the
// leading shape is the answers'.
struct QueryArrays {
  InArray<float> origins, directions;
  std::vector<size_t> shape;  // without the trailing 3
  size_t count = 0;
  // (H, W, 3) arrays are an image's rays: traced in square blocks.
  size_t row_length() const { return shape.size() == 2 ? shape[1] : 0; }
};

QueryArrays query_arrays(nb::handle origins, nb::handle directions) {
  if (directions.is_none()) {
    // One (..., 6) array, origin then direction, as Open3D's cast_rays takes
    // its rays: split here into the two (..., 3) arrays below.
    nb::object np = nb::module_::import_("numpy");
    nb::object rays;
    try {
      rays = np.attr("asarray")(origins, "dtype"_a = "float32");
    } catch (nb::python_error&) {
      throw rayfold::InputError("", "rays is not an array of numbers");
    }
    const nb::tuple dims = nb::cast<nb::tuple>(rays.attr("shape"));
    std::vector<size_t> d(dims.size());
    for (size_t i = 0; i < d.size(); ++i) d[i] = nb::cast<size_t>(dims[i]);
    if (d.empty() || d.back() != 6)
      throw rayfold::InputError("", "rays given alone must have shape (..., 6), each an origin and a direction as "
                                    "Open3D's cast_rays takes them, not " +
                                        shape_text(d.size(), d.data()) +
                                        "; or give origins and directions apart, each (..., 3)");
    nb::object item = rays.attr("__getitem__");
    const nb::object o = item(nb::make_tuple(nb::ellipsis(), nb::slice(0, 3)));
    const nb::object dir = item(nb::make_tuple(nb::ellipsis(), nb::slice(3, 6)));
    return query_arrays(o, dir);  // each made contiguous there; the arrays keep them alive
  }
  QueryArrays q{as_array<float>(origins, "float32", "origins"), as_array<float>(directions, "float32", "directions"),
                {}, 0};
  auto dims = [](const InArray<float>& a) {
    std::vector<size_t> d(a.ndim());
    for (size_t i = 0; i < a.ndim(); ++i) d[i] = a.shape(i);
    return d;
  };
  const std::vector<size_t> o = dims(q.origins), d = dims(q.directions);
  if (o.empty() || o.back() != 3)
    throw rayfold::InputError("", "origins must have shape (..., 3), not " + shape_text(o.size(), o.data()));
  if (d != o)
    throw rayfold::InputError("", "directions must have the shape of origins, " + shape_text(o.size(), o.data()) +
                                      ", not " + shape_text(d.size(), d.data()));
  q.shape.assign(o.begin(), o.end() - 1);
  q.count = q.origins.size() / 3;
  return q;
}

// A query's warnings as Python RuntimeWarnings (a query returns arrays,
// with no object to carry them as a G-buffer does).
void warn_all(const std::vector<std::string>& warnings) {
  for (const std::string& w : warnings)
    if (PyErr_WarnEx(PyExc_RuntimeWarning, ("rayfold: " + w).c_str(), 1) != 0) throw nb::python_error();
}

template <class T>
nb::object shaped(std::vector<T>&& v, const std::vector<size_t>& lead, size_t per_ray) {
  std::vector<size_t> shape = lead;
  if (per_ray > 1) shape.push_back(per_ray);
  return plane_to_numpy(std::move(v), shape);
}

// rayfold.Camera: making views, their rays, pickling.
void bind_camera(nb::module_& m) {
  nb::class_<rayfold::Camera>(m, "Camera",
                              "A pinhole camera. Pixel (x, y) has its centre at (x + 0.5, y + 0.5) from the top-left "
                              "corner, rows going down; depth is the distance along ray_directions().")
      .def_static(
          "look_at",
          [](nb::handle eye, nb::handle target, nb::handle up, double vfov_deg, int width, int height) {
            return rayfold::Camera::look_at(as_vec3(eye, "eye"), as_vec3(target, "target"), as_vec3(up, "up"), vfov_deg,
                                            width, height);
          },
          "eye"_a, "target"_a, "up"_a, "vfov_deg"_a, "width"_a, "height"_a,
          "A camera at eye looking at target, image +y along up, vertical field of view in degrees, square pixels.")
      .def_static(
          "stereo_pair",
          [](nb::handle eye, nb::handle target, nb::handle up, double vfov_deg, int width, int height,
             double baseline) {
            const auto pair = rayfold::Camera::stereo_pair(as_vec3(eye, "eye"), as_vec3(target, "target"),
                                                           as_vec3(up, "up"), vfov_deg, width, height, baseline);
            return std::make_pair(pair[0], pair[1]);
          },
          "eye"_a, "target"_a, "up"_a, "vfov_deg"_a, "width"_a, "height"_a, "baseline"_a,
          "A parallel-axis stereo pair (left, right) around look_at(eye, target, ...): eye and target moved "
          "baseline / 2 along the camera's right vector each way.")
      .def_static(
          "orthographic",
          [](nb::handle eye, nb::handle target, nb::handle up, double half_height, int width, int height) {
            return rayfold::Camera::orthographic(as_vec3(eye, "eye"), as_vec3(target, "target"), as_vec3(up, "up"),
                                                 half_height, width, height);
          },
          "eye"_a, "target"_a, "up"_a, "half_height"_a, "width"_a, "height"_a,
          "Parallel rays along the view direction from the plane through eye; the image half_height world units "
          "above and below the axis. Depth is the distance from that plane.")
      .def_static(
          "from_matrix",
          [](nb::handle camera_to_world, double fx, double fy, double cx, double cy, int width, int height,
             const std::string& convention) {
            return rayfold::Camera::from_matrix(as_matrix4(camera_to_world, "camera_to_world"), {fx, fy, cx, cy}, width,
                                                height, parse_convention(convention));
          },
          "camera_to_world"_a, "fx"_a, "fy"_a, "cx"_a, "cy"_a, "width"_a, "height"_a, nb::kw_only(), "convention"_a,
          "A camera from a rigid 4x4 camera-to-world matrix and pinhole intrinsics in pixels (pixel centres at "
          "+0.5). convention: 'opencv' (+x right, +y down, +z forward; COLMAP) or 'opengl' (+y up, -z forward; "
          "Blender, NeRF).")
      .def_static(
          "_read_nerf",
          [](const std::string& path, int width, int height) {
            std::vector<std::string> ignored;
            auto views = rayfold::Camera::from_nerf(path, width, height, &ignored);
            return std::make_pair(std::move(views), std::move(ignored));
          },
          "path"_a, "width"_a, "height"_a)
      .def_static(
          "_read_file",
          [](const std::string& path, int width, int height, bool lenient) {
            std::vector<std::string> ignored;
            std::vector<std::pair<size_t, std::string>> skipped;
            auto views = rayfold::Camera::from_file(path, width, height, &ignored, lenient ? &skipped : nullptr);
            return std::make_tuple(std::move(views), std::move(ignored), std::move(skipped));
          },
          "path"_a, "width"_a, "height"_a, "lenient"_a = false)
      .def_static(
          "_read_colmap",
          [](const std::string& dir, bool lenient) {
            std::vector<std::pair<size_t, std::string>> skipped;
            auto views = rayfold::Camera::from_colmap(dir, lenient ? &skipped : nullptr);
            return std::make_pair(std::move(views), std::move(skipped));
          },
          "dir"_a, "lenient"_a = false)
      .def("__getstate__",
           [](const rayfold::Camera& c) {
             const std::string b = c.to_bytes();
             return nb::bytes(b.data(), b.size());
           })
      .def("__setstate__",
           [](rayfold::Camera& c, const nb::bytes& state) {
             new (&c) rayfold::Camera(rayfold::Camera::from_bytes(std::string(state.c_str(), state.size())));
           })
      .def_prop_ro("width", &rayfold::Camera::width)
      .def_prop_ro("height", &rayfold::Camera::height)
      .def_prop_ro(
          "camera_to_world", [](const rayfold::Camera& c) { return matrix_to_numpy(c.camera_to_world()); },
          "4x4 float64, OpenGL axes (+y up, -z forward); camera_to_world_in('opencv') for OpenCV's.")
      .def(
          "camera_to_world_in",
          [](const rayfold::Camera& c, const std::string& convention) {
            return matrix_to_numpy(c.camera_to_world(parse_convention(convention)));
          },
          "convention"_a)
      .def_prop_ro("world_to_camera", [](const rayfold::Camera& c) { return matrix_to_numpy(c.world_to_camera()); })
      .def_prop_ro(
          "intrinsics",
          [](const rayfold::Camera& c) {
            const rayfold::Intrinsics k = c.intrinsics();
            return std::make_tuple(k.fx, k.fy, k.cx, k.cy);
          },
          "(fx, fy, cx, cy) in pixels, pixel centres at +0.5.")
      .def_prop_ro("eye", [](const rayfold::Camera& c) { return c.eye(); })
      .def_prop_ro("vfov_deg", &rayfold::Camera::vfov_degrees)
      .def_prop_ro("is_orthographic", &rayfold::Camera::is_orthographic)
      .def(
          "ray_origins", [](const rayfold::Camera& c) { return per_pixel(c, &rayfold::Camera::ray_origin); },
          "(H, W, 3) float64 world-space ray origins (the eye, or an orthographic camera's plane): a hit lies at "
          "origin + depth * direction.")
      .def_prop_ro("can_fold_columns", &rayfold::Camera::can_fold_columns)
      .def_prop_ro("can_fold_rows", &rayfold::Camera::can_fold_rows)
      .def(
          "ray_directions", [](const rayfold::Camera& c) { return per_pixel(c, &rayfold::Camera::ray_direction); },
          "(H, W, 3) float64 unit world-space ray directions: a hit lies at eye + depth * direction.")
      .def("__repr__", [](const rayfold::Camera& c) {
        const rayfold::Vec3 e = c.eye();
        std::ostringstream s;
        s << "rayfold.Camera(" << c.width() << "x" << c.height() << ", eye=(" << e[0] << ", " << e[1] << ", " << e[2]
          << "), vfov_deg=" << c.vfov_degrees() << ")";
        return s.str();
      });
}

// rayfold.GBuffer: the planes of a render, named as the channels, and its EXR.
void bind_gbuffer(nb::module_& m) {
  auto gbuffer_class =
      nb::class_<PyGBuffer>(m, "GBuffer",
                            "One render's hit info: numpy planes, rows from the top; a plane not asked for (channels=) "
                            "is None.")
          .def_ro("width", &PyGBuffer::width)
          .def_ro("height", &PyGBuffer::height)
          .def_ro("fold", &PyGBuffer::fold,
                  "the fold traced ('none', 'y', 'x', 'xy'): the one asked for, less what the "
                  "camera's principal point cannot mirror")
          .def_ro("rays", &PyGBuffer::rays)
          .def_ro("hits", &PyGBuffer::hits)
          .def_ro("trace_ms", &PyGBuffer::trace_ms)
          .def_ro("frame_ms", &PyGBuffer::frame_ms)
          .def_prop_ro(
              "time", [](const PyGBuffer& g) { return std::isnan(g.time) ? std::optional<double>() : g.time; },
              "the pose it shows: the scene's time when rendered (render's time=), seconds; None for the rest "
              "pose (written to the EXR as rayfold:time)")
          .def_ro("views_in_trace", &PyGBuffer::views_in_trace,
                  "views traced together with this one, itself included (Scene.render_views)")
          .def_ro("warnings", &PyGBuffer::warnings)
          .def_ro("camera", &PyGBuffer::camera)
          .def_ro("kernel", &PyGBuffer::kernel, "the kernel that traced it: 'tile', 'single' or 'cpu reference'")
          .def_ro("kernel_reason", &PyGBuffer::kernel_reason, "why that kernel ('CPU device', 'chosen', ...)")
          .def_prop_ro(
              "stages",
              [](const PyGBuffer& g) {
                const rayfold::StageTimes& t = g.stages;
                nb::dict d;
                d["cull_ms"] = t.cull_ms;
                d["tlas_ms"] = t.tlas_ms;
                d["upload_ms"] = t.upload_ms;
                d["ray_list_ms"] = t.ray_list_ms;
                d["trace_ms"] = t.trace_ms;
                d["readback_ms"] = t.readback_ms;
                return d;
              },
              "where the render's time went, ms per stage (a trace of several views: the whole pass's)")
          .def_prop_ro(
              "top_level",
              [](const PyGBuffer& g) {
                nb::dict d;
                d["scene_instances"] = g.top_level.scene_instances;
                d["traced_instances"] = g.top_level.traced_instances;
                d["out_of_range"] = g.top_level.out_of_range;
                d["sah_cost"] = g.top_level.sah_cost;
                return d;
              },
              "the top-level tree traced: the scene's renderable instances, those in the tree after culling (copies "
              "per view and mirror included), those beyond the float range, its SAH cost")
          .def_prop_ro(
              "depth_kind",
              [](const PyGBuffer& g) { return g.depth_kind == rayfold::Depth::planar ? "planar" : "distance"; },
              "what depth measures: 'distance' along the pixel's ray or 'planar' along the camera's axis")
          .def_prop_ro(
              "exact_depth", [](const PyGBuffer& g) { return g.exact_depth; },
              "whether depth came from each pixel's exact ray in double-float (render(exact_depth=True))")
          .def(
              "write_exr",
              [](const PyGBuffer& g, const std::filesystem::path& path, const PyScene& scene,
                 const std::string& compression) {
                const rayfold::ExrCompression method = rayfold::exr_compression(compression);
                const rayfold::GBuffer core = from_python(g);
                nb::gil_scoped_release release;
                rayfold::write_exr(path.string(), core, g.camera, scene.scene, method);
              },
              "path"_a, "scene"_a, "compression"_a = "zip",
              "Writes the planes this G-buffer has as `rayfold render -o` writes a view (channels Z, N.X, N.Y, N.Z, U, "
              "V, InstanceID, PrimitiveID and those of the resolved planes, docs/channels.md; the camera and scene's "
              "instance names in the header; InputError for a scene without the G-buffer's instance or label ids). The "
              "file appears "
              "whole or not at all. compression: OpenEXR's lossless 'zip' (default), 'zips', 'piz', 'rle' or 'none' "
              "(3 to 4 times faster to write, 10 times the bytes). Releases the GIL.");

  add_plane_properties(gbuffer_class);
}

// rayfold.Scene: loading, pickling, editing, and what it holds.
nb::class_<PyScene> bind_scene(nb::module_& m) {
  auto scene_class = nb::class_<PyScene>(m, "Scene", "Meshes and instances, from a glTF 2.0 file or built in memory.");
  scene_class
      .def(
          "__init__",
          [](PyScene* self, std::optional<std::filesystem::path> path, int scene, int camera,
             std::optional<double> time, const std::string& label_key) {
            // Constructed only once loading succeeded: a throwing __init__
            // leaves nothing behind to destroy.
            rayfold::Scene loaded;
            if (path) {
              rayfold::LoadOptions o;
              o.scene = scene;
              o.camera = camera;
              if (time && !std::isfinite(*time))
                throw rayfold::InputError(
                    path->string(), "time must be a finite number of seconds or None, not " + std::to_string(*time));
              o.time = time ? *time : NAN;
              o.label_key = label_key;
              nb::gil_scoped_release release;
              loaded = rayfold::Scene::load(path->string(), o);
            }
            new (self) PyScene();
            self->scene = std::move(loaded);
          },
          "path"_a = nb::none(), "scene"_a = -1, "camera"_a = -1, "time"_a = nb::none(), "label_key"_a = "",
          "Loads a .gltf or .glb file (scene, camera: the file's indices; time: seconds into its animations; "
          "label_key: the member of a node's extras that labels it for the label channel, '' for the whole "
          "extras), or a scene file Scene.save wrote, trees and all; without a path, makes an empty scene.")
      .def(
          "to_bytes",
          [](PyScene& s) {
            const std::string b = locked(s, [&] { return s.scene.to_bytes(); });
            return nb::bytes(b.data(), b.size());
          },
          "The scene and its bottom-level trees (built now, once) as versioned, checksummed bytes; "
          "Scene.from_bytes reads them back without building a tree. Pickling a Scene uses them.")
      .def_static(
          "from_bytes",
          [](const nb::bytes& b) {
            auto out = std::make_shared<PyScene>();
            {
              nb::gil_scoped_release release;  // b stays alive: the caller holds it
              out->scene = rayfold::Scene::from_bytes(b.c_str(), b.size());
            }
            return out;
          },
          "bytes"_a,
          "A scene from Scene.to_bytes, its trees as they were built; InputError for bytes cut short, damaged or "
          "written by another rayfold version or machine.")
      .def(
          "save",
          [](PyScene& s, const std::filesystem::path& path) { locked(s, [&] { s.scene.save(path.string()); }); },
          "path"_a,
          "Writes to_bytes to a file, whole or not at all; Scene(path) loads it back without building a tree.")
      .def("__getstate__",
           [](PyScene& s) {
             const std::string b = locked(s, [&] { return s.scene.to_bytes(); });
             return nb::bytes(b.data(), b.size());
           })
      .def("__setstate__",
           [](PyScene* self, const nb::bytes& b) {
             rayfold::Scene loaded;
             {
               nb::gil_scoped_release release;
               loaded = rayfold::Scene::from_bytes(b.c_str(), b.size());
             }
             new (self) PyScene();
             self->scene = std::move(loaded);
           })
      .def(
          "add_mesh",
          [](PyScene& s, nb::handle positions, nb::handle indices, const std::string& name) {
            const InArray<float> p = as_array<float>(positions, "float32", "positions");
            if (p.ndim() != 2 || p.shape(1) != 3) throw rayfold::InputError("", "positions must have shape (N, 3)");
            const InArray<int64_t> i = as_array<int64_t>(indices, "int64", "indices");
            std::vector<uint32_t> idx(i.size());
            for (size_t k = 0; k < idx.size(); ++k) {
              if (i.data()[k] < 0 || i.data()[k] > 0xFFFFFFFEll)
                throw rayfold::InputError(
                    "", "index " + std::to_string(k) + " is " + std::to_string(i.data()[k]) + ", not a vertex index");
              idx[k] = static_cast<uint32_t>(i.data()[k]);
            }
            return locked(s, [&] { return s.scene.add_mesh(p.data(), p.shape(0), idx.data(), idx.size(), name); });
          },
          "positions"_a, "indices"_a, "name"_a = "",
          "Adds a mesh: positions (N, 3), indices (M, 3) or (3M,); returns its index.")
      .def(
          "add_instance",
          [](PyScene& s, uint32_t mesh, nb::handle world_from_object, const std::string& name) {
            const rayfold::Matrix4 m4 =
                world_from_object.is_none() ? rayfold::kIdentity : as_matrix4(world_from_object, "world_from_object");
            return locked(s, [&] { return s.scene.add_instance(mesh, m4, name); });
          },
          "mesh"_a, "world_from_object"_a = nb::none(), "name"_a = "",
          "Places a mesh (a 4x4 matrix; None or left out: where the mesh's own coordinates put it, the identity); "
          "returns the instance id.")
      .def(
          "set_transform",
          [](PyScene& s, uint32_t instance, nb::handle world_from_object) {
            const rayfold::Matrix4 m4 = as_matrix4(world_from_object, "world_from_object");
            locked(s, [&] { s.scene.set_transform(instance, m4); });
          },
          "instance"_a, "world_from_object"_a, "Moves an instance; the next render shows it there.")
      .def(
          "transform", [](PyScene& s, uint32_t instance) { return matrix_to_numpy(s.scene.transform(instance)); },
          "instance"_a)
      .def(
          "set_time", [](PyScene& s, double seconds) { locked(s, [&] { s.scene.set_time(seconds); }); }, "seconds"_a,
          "Poses the file's animations at this time (nan: rest); the next render shows the pose.")
      .def_prop_ro("animated", [](PyScene& s) { return s.scene.animated(); })
      .def_prop_ro("animation_end", [](PyScene& s) { return s.scene.animation_end(); })
      .def(
          "instance_mesh", [](PyScene& s, uint32_t instance) { return s.scene.instance_mesh(instance); }, "instance"_a)
      .def(
          "mesh_positions",
          [](PyScene& s, uint32_t mesh) {
            std::vector<float> p = s.scene.mesh_positions(mesh);
            const size_t n = p.size() / 3;
            return to_numpy(std::move(p), {n, 3});
          },
          "mesh"_a, "(N, 3) float32 object-space positions")
      .def(
          "mesh_triangles",
          [](PyScene& s, uint32_t mesh) {
            std::vector<uint32_t> i = s.scene.mesh_indices(mesh);
            const size_t n = i.size() / 3;
            return to_numpy(std::move(i), {n, 3});
          },
          "mesh"_a, "(M, 3) uint32 vertex indices; primitive_id indexes the rows")
      .def_prop_ro("instance_names", [](PyScene& s) { return s.scene.instance_names(); })
      .def_prop_ro(
          "labels", [](PyScene& s) { return locked(s, [&] { return s.scene.labels(); }); },
          "The label channel's table: label i's text (Scene.load's label_key value of the node's extras, a string "
          "as is, anything else as JSON); labels[0] is '', no label. Read from the file on first use.")
      .def_prop_ro("camera_names", [](PyScene& s) { return s.scene.camera_names(); })
      .def_prop_ro("warnings", [](PyScene& s) { return s.scene.warnings(); })
      .def_prop_ro("path", [](PyScene& s) { return s.scene.path(); })
      .def_prop_ro(
          "_reads_file", [](PyScene& s) { return s.scene.state()->file != nullptr; },
          "Whether this Scene's renders read attributes, materials and labels from its glTF file (one loaded "
          "from a file; not one built in memory or from a scene file's bytes, which keep positions only).")
      .def_prop_ro("mesh_count", [](PyScene& s) { return s.scene.mesh_count(); })
      .def_prop_ro("instance_count", [](PyScene& s) { return s.scene.instance_count(); })
      .def_prop_ro("triangle_count", [](PyScene& s) { return s.scene.triangle_count(); })
      .def_prop_ro(
          "bounds", [](PyScene& s) { return s.scene.bounds(); }, "(min x, y, z, max x, y, z) at rest")
      .def(
          "default_camera", [](PyScene& s, int width, int height) { return s.scene.default_camera(width, height); },
          "width"_a, "height"_a,
          "The file's camera at this size, or a chosen view: an object whole from outside, a room from inside, "
          "looking along it (as `rayfold render` chooses).");
  return scene_class;
}

// Scene.render and Scene.render_views: G-buffers of views.
void bind_scene_rendering(nb::class_<PyScene>& scene_class) {
  scene_class
      .def(
          "render",
          [](PyScene& s, const rayfold::Camera& camera, const std::string& fold, const std::string& backend,
             const std::string& device, const std::string& kernel, unsigned threads, nb::handle channels,
             const std::string& depth, bool exact_depth, nb::handle flow_to, std::optional<double> time) {
            const rayfold::RendererOptions o = renderer_options(backend, device, kernel, threads, depth, exact_depth);
            const unsigned mask = parse_channels(channels);
            // None is the scene's own pose; NaN, the C++ API's word for the
            // rest pose, is no time a caller means here.
            if (time && !std::isfinite(*time))
              throw rayfold::InputError(
                  "", "render: time must be a finite number of seconds or None, not " + std::to_string(*time));
            // flow_to: a Camera, or (Camera, time).
            std::optional<rayfold::FlowTo> to;
            if (!flow_to.is_none()) {
              if (!(mask & rayfold::kFlowChannels))
                throw rayfold::InputError("", "flow_to is given, but channels name neither flow nor flow_visible");
              if (nb::isinstance<rayfold::Camera>(flow_to)) {
                to = rayfold::FlowTo{nb::cast<rayfold::Camera>(flow_to)};
              } else {
                // A (Camera, time) pair, as a tuple or a list.
                const bool two =
                    (nb::isinstance<nb::tuple>(flow_to) || nb::isinstance<nb::list>(flow_to)) && nb::len(flow_to) == 2;
                const bool pair = two && nb::isinstance<rayfold::Camera>(flow_to[0]);
                if (two && !pair && nb::isinstance<rayfold::Camera>(flow_to[1]))
                  throw rayfold::InputError("", "flow_to is (time, Camera); give it as (Camera, time)");
                double t = NAN;
                if (pair && !flow_to[1].is_none() && (!nb::try_cast<double>(flow_to[1], t) || !std::isfinite(t)))
                  throw rayfold::InputError("", "flow_to's time must be a finite number of seconds or None");
                if (!pair)
                  throw rayfold::InputError("", "flow_to must be a Camera or (Camera, time), not " +
                                                    nb::cast<std::string>(nb::str(nb::type_name(flow_to.type()))));
                to = rayfold::FlowTo{nb::cast<rayfold::Camera>(flow_to[0]), t};
              }
            }
            const std::string key = backend + "|" + device + "|" + kernel + "|" + std::to_string(threads) + "|" +
                                    depth + (exact_depth ? "|exact" : "");
            auto cached = [&]() -> rayfold::Renderer& {
              std::unique_ptr<rayfold::Renderer>& r = s.renderers[key];
              if (!r) r = std::make_unique<rayfold::Renderer>(s.scene, o);
              return *r;
            };
            return render_locked(s, cached, camera, fold, mask, s.plans[key], to, time);
          },
          "camera"_a, "fold"_a = "none", "backend"_a = "opencl", "device"_a = "", "kernel"_a = "auto", "threads"_a = 0,
          "channels"_a = nb::none(), "depth"_a = "distance", "exact_depth"_a = false, "flow_to"_a = nb::none(),
          "time"_a = nb::none(),
          "Renders a G-buffer. The trees and kernels for these options are built on first use and kept. fold: "
          "'none', 'y', 'x', 'xy' (the same bits, less work), or 'auto': the fold (and, with kernel='auto', the "
          "kernel) the cost model predicts fastest from a probe of sampled tiles (docs/cost_model.md), chosen on "
          "the first render of this size and intrinsics and kept (GBuffer.fold says which). channels: "
          "the planes to fill (a list or 'depth,instance_id'; default the visibility buffer's: depth, normal, "
          "barycentrics, instance_id, primitive_id), the others None. depth: 'distance' "
          "along each pixel's ray, or 'planar' along the camera's axis. exact_depth: each depth from the pixel's "
          "exact ray in double-float, within 2^-24 of the exact value (slower: about 1.2x to 1.5x the frame). "
          "flow_to: the Camera, or (Camera, time), that the channels flow and flow_visible go to. time: the "
          "scene posed at this time for this render (seconds), put back after it. Releases the GIL.")
      .def(
          "render_views",
          [](PyScene& s, const std::vector<rayfold::Camera>& cameras, const std::string& fold, nb::handle align_arg,
             const std::string& backend, const std::string& device, const std::string& kernel, unsigned threads,
             nb::handle channels, const std::string& depth, bool exact_depth) {
            const int align = parse_align(align_arg);
            if (fold != "auto") parse_fold(fold);
            const rayfold::RendererOptions o = renderer_options(backend, device, kernel, threads, depth, exact_depth);
            const unsigned mask = parse_channels(channels);
            const std::string key = backend + "|" + device + "|" + kernel + "|" + std::to_string(threads) + "|" +
                                    depth + (exact_depth ? "|exact" : "");
            std::vector<rayfold::GBuffer> gs(cameras.size());
            locked(s, [&] {
              std::unique_ptr<rayfold::Renderer>& r = s.renderers[key];
              if (!r) r = std::make_unique<rayfold::Renderer>(s.scene, o);
              const auto [f, a] = s.plans[key].plan(*r, cameras, fold, align);
              r->render_views(
                  cameras, [&](size_t i, rayfold::GBuffer&& g) { gs[i] = std::move(g); }, f, a, planes_for(mask),
                  [&](size_t i, rayfold::GBuffer& g) { take_planes(g, cameras[i], planes_for(mask)); });
            });
            std::vector<PyGBuffer> out;
            for (size_t i = 0; i < gs.size(); ++i) {
              keep_asked(gs[i], mask);
              out.push_back(to_python(std::move(gs[i]), cameras[i]));
            }
            return out;
          },
          "cameras"_a, "fold"_a = "none", "align"_a = 0, "backend"_a = "opencl", "device"_a = "", "kernel"_a = "auto",
          "threads"_a = 0, "channels"_a = nb::none(), "depth"_a = "distance", "exact_depth"_a = false,
          "Renders a list of views, one GBuffer each. Views of the same size and intrinsics are traced together, up "
          "to align per trace (0 or 'all': as many as one holds; 1: each alone; 'auto': as the cost model predicts "
          "fastest, chosen on the first list of this size and intrinsics and kept); every view's bits equal "
          "render(view). fold, channels, depth and exact_depth as in render; flow and flow_visible go from each view "
          "to the next (render(view, flow_to=next)), the last view's NaN. Releases the GIL.");
}

// Scene.intersect and Scene.occluded: rays from anywhere, on a renderer kept per option set.
void bind_scene_queries(nb::class_<PyScene>& scene_class) {
  auto scene_renderer = [](PyScene& s, const std::string& backend, const std::string& device, unsigned threads)
      -> rayfold::Renderer& {
    const rayfold::RendererOptions o = renderer_options(backend, device, "auto", threads, "distance");
    const std::string key = backend + "|" + device + "|auto|" + std::to_string(threads) + "|distance";
    std::unique_ptr<rayfold::Renderer>& r = s.renderers[key];
    if (!r) r = std::make_unique<rayfold::Renderer>(s.scene, o);
    return *r;
  };
  scene_class.def(
      "intersect",
      [scene_renderer](PyScene& s, nb::handle origins, nb::handle directions, float tmin, float tmax,
                       const std::string& backend, const std::string& device, unsigned threads, nb::handle channels) {
        const unsigned mask = parse_channels(channels);
        const QueryArrays q = query_arrays(origins, directions);
        rayfold::RayHits h;
        take_planes(q.count, mask, h.t, h.normal, h.uv, h.instance_id, h.primitive_id);
        locked(s, [&] {
          scene_renderer(s, backend, device, threads)
              .intersect_into(h, q.origins.data(), q.directions.data(), q.count, tmin, tmax, q.row_length(), mask);
        });
        warn_all(h.warnings);
        nb::dict out;
        const auto put = [&](const char* key, unsigned bit, auto&& plane, size_t per_ray) {
          if (mask & bit)
            out[key] = shaped(std::move(plane), q.shape, per_ray);
          else
            out[key] = nb::none();
        };
        put("t", rayfold::kDepth, h.t, 1);
        put("instance_id", rayfold::kInstanceId, h.instance_id, 1);
        put("primitive_id", rayfold::kPrimitiveId, h.primitive_id, 1);
        put("uv", rayfold::kUv, h.uv, 2);
        put("normal", rayfold::kNormal, h.normal, 3);
        return out;
      },
      "origins"_a, "directions"_a = nb::none(), "tmin"_a = 0.0f, "tmax"_a = INFINITY, "backend"_a = "opencl",
      "device"_a = "", "threads"_a = 0, "channels"_a = nb::none(),
      "The closest hit of each ray with tmin < t <= tmax. origins, directions: (..., 3) world space (float64 is "
      "rounded once to float32), or one (..., 6) array of rays, origin then direction, as Open3D's cast_rays "
      "takes; directions need not be unit length, t is along them. Returns a dict of arrays "
      "of the leading shape: t (inf on a miss), instance_id and primitive_id (MISS on a miss), uv (..., 2), "
      "normal (..., 3), as a G-buffer's; channels names the ones to fill (a list or 't,instance_id'; default all), "
      "the others None, and without 'normal' none is computed. The same bits on every backend. InputError names the first ray whose "
      "origin or direction is not finite or whose direction is zero; what the answers may have lost (as "
      "GBuffer.warnings) comes as a RuntimeWarning. Releases the GIL.");
  scene_class.def(
      "render_reference",
      [](PyScene& s, const rayfold::Camera& camera, unsigned threads) {
        rayfold::ReferenceImage r = locked(s, [&] { return rayfold::render_reference(s.scene, camera, threads); });
        const size_t h = r.height, w = r.width;
        nb::dict out;
        out["depth"] = to_numpy(std::move(r.depth), {h, w});
        out["instance_id"] = to_numpy(std::move(r.instance_id), {h, w});
        out["primitive_id"] = to_numpy(std::move(r.primitive_id), {h, w});
        return out;
      },
      "camera"_a, "threads"_a = 0,
      "The double-precision ground truth of a view, what rayfold's benches measure every tracer against: each "
      "pixel's exact ray (the camera model in double, not the float ray a render traces) through the scene's "
      "trees with the watertight test in double, on the geometry as the scene states it (mesh vertices through "
      "the instance transforms, unrounded: world_triangles' float rounding counts as error). A dict: depth (H, W) float64, the distance along the ray as "
      "GBuffer.depth (inf on a miss), instance_id and primitive_id (H, W) uint32 (MISS on a miss). For "
      "measuring accuracy, not for rendering: tens of times slower than a render. Releases the GIL.");
  scene_class.def(
      "occluded",
      [scene_renderer](PyScene& s, nb::handle origins, nb::handle directions, float tmin, float tmax,
                       const std::string& backend, const std::string& device, unsigned threads) {
        const QueryArrays q = query_arrays(origins, directions);
        std::vector<std::string> warnings;
        std::vector<uint8_t> hit = locked(s, [&] {
          return scene_renderer(s, backend, device, threads)
              .occluded(q.origins.data(), q.directions.data(), q.count, tmin, tmax, &warnings, q.row_length());
        });
        warn_all(warnings);
        nb::object flags = shaped(std::move(hit), q.shape, 1);
        return flags.attr("astype")("bool");
      },
      "origins"_a, "directions"_a = nb::none(), "tmin"_a = 0.0f, "tmax"_a = INFINITY, "backend"_a = "opencl",
      "device"_a = "", "threads"_a = 0,
      "Whether each ray has any hit with tmin < t <= tmax (bool array of the leading shape); each ray stops at "
      "the first hit found. Inputs as intersect. Releases the GIL.");
}

// The module's functions: files, devices, output names.
void bind_functions(nb::module_& m) {
  m.def(
      "read_exr",
      [](const std::filesystem::path& path) {
        rayfold::GBuffer g = [&] {
          nb::gil_scoped_release release;
          return rayfold::read_exr(path.string());
        }();
        const size_t h = g.height, w = g.width;
        nb::dict out;
        for (const rayfold::core::PlaneSpec& spec : rayfold::core::plane_specs()) {
          if (!(g.channels & spec.bit)) continue;
          const std::initializer_list<size_t> flat = {h, w}, deep = {h, w, size_t(spec.components)};
          const auto shape = spec.components == 1 ? flat : deep;
          out[spec.name] =
              spec.floats ? to_numpy(std::move(g.*spec.floats), shape) : to_numpy(std::move(g.*spec.ids), shape);
          // The barycentrics under their older name too, as GBuffer.uv.
          if (spec.bit == rayfold::kBarycentrics) out["uv"] = out[spec.name];
        }
        return out;
      },
      "path"_a,
      "The planes of an EXR rayfold wrote (GBuffer.write_exr, rayfold render -o), bit for bit, as a dict with the "
      "GBuffer's plane names and shapes (depth, normal, barycentrics (also as uv), instance_id, primitive_id, "
      "shading_normal, texcoord, texcoord1, position, object_position, material_id), holding the planes the file "
      "has. InputError naming the file otherwise.");
  m.def(
      "read_exr_header",
      [](const std::filesystem::path& path) {
        const rayfold::ExrHeader h = [&] {
          nb::gil_scoped_release release;
          return rayfold::read_exr_header(path.string());
        }();
        nb::dict out;
        out["width"] = h.width;
        out["height"] = h.height;
        out["camera"] = h.camera ? nb::cast(*h.camera) : nb::none();
        out["depth_kind"] = h.depth_kind == rayfold::Depth::planar ? "planar" : "distance";
        out["instance_names"] = h.instance_names;
        out["labels"] = h.labels;
        out["fold"] = h.fold;
        out["scene"] = h.scene;
        out["version"] = h.version;
        out["time"] = std::isnan(h.time) ? nb::none() : nb::cast(h.time);
        return out;
      },
      "path"_a,
      "The header of an EXR rayfold wrote, as a dict: width, height, camera (a Camera with the view's pose and "
      "intrinsics, None in another EXR: camera.ray_origins() + depth * camera.ray_directions() are the hits, "
      "for depth_kind 'distance'), depth_kind ('distance' or 'planar'), instance_names (by instance_id), labels "
      "(by label), fold, scene, version, time (the pose's seconds, GBuffer.time; None for the rest pose). "
      "InputError naming the file when it cannot be read.");
  m.def(
      "_plane_specs",
      [] {
        nb::list out;
        for (const rayfold::core::PlaneSpec& spec : rayfold::core::plane_specs()) {
          nb::dict d;
          d["name"] = spec.name;
          d["alias"] = spec.alias ? nb::object(nb::str(spec.alias)) : nb::none();
          d["exr_layer"] = spec.exr_layer;
          d["components"] = spec.components;
          d["dtype"] = spec.floats ? "float32" : "uint32";
          d["visibility"] = (spec.bit & rayfold::kAllChannels) != 0;
          out.append(d);
        }
        return out;
      },
      "The G-buffer's planes, one dict each (name, alias, exr_layer, components, dtype, visibility), in their "
      "channel bits' order (output/channels.h).");
  m.def(
      "opencl_devices",
      [] {
        std::vector<std::string> lines;
        std::istringstream text(rayfold::opencl_devices());
        for (std::string line; std::getline(text, line);)
          if (!line.empty()) lines.push_back(line.substr(line.find_first_not_of(' ')));
        return lines;
      },
      "The OpenCL devices this machine offers, one string each ('platform: name (CPU, N compute units, "
      "version)'): what device= picks among (the first whose platform or name contains it).");
  m.def("_view_files", &rayfold::view_files, "pattern"_a, "names"_a,
        "Each view's file under pattern's one %s (None for a view named None); InputError for another field, a "
        "name that leaves no file name or two views that would write one file.");
  m.def(
      "_channels_read_attributes",
      [](nb::handle channels) { return rayfold::detail::attributes_for(parse_channels(channels)) != 0; },
      "channels"_a.none(),
      "Whether these channels (as render takes them) read the glTF's attributes, materials or labels, which a "
      "scene file does not keep; InputError for an unknown channel.");
  m.def(
      "_check_exr_compression", [](const std::string& name) { rayfold::exr_compression(name); }, "name"_a,
      "InputError unless name is an EXR compression GBuffer.write_exr takes.");
}

// rayfold.Renderer: a renderer with fixed options, and its choices.
void bind_renderer(nb::module_& m) {
  nb::class_<PyRenderer>(m, "Renderer", "A renderer of one scene with fixed options (Scene.render keeps these).")
      .def(
          "__init__",
          [](PyRenderer* self, std::shared_ptr<PyScene> scene, const std::string& backend, const std::string& device,
             const std::string& kernel, unsigned threads, const std::string& depth, bool exact_depth) {
            const rayfold::RendererOptions o = renderer_options(backend, device, kernel, threads, depth, exact_depth);
            auto renderer = locked(*scene, [&] { return std::make_unique<rayfold::Renderer>(scene->scene, o); });
            new (self) PyRenderer{std::move(scene), std::move(renderer)};
          },
          "scene"_a, "backend"_a = "opencl", "device"_a = "", "kernel"_a = "auto", "threads"_a = 0,
          "depth"_a = "distance", "exact_depth"_a = false)
      .def(
          "render",
          [](PyRenderer& r, const rayfold::Camera& camera, const std::string& fold, nb::handle channels) {
            const unsigned mask = parse_channels(channels);
            return render_locked(
                *r.scene, [&]() -> rayfold::Renderer& { return *r.renderer; }, camera, fold, mask, r.plans);
          },
          "camera"_a, "fold"_a = "none", "channels"_a = nb::none(), "fold and channels as in Scene.render.")
      .def(
          "choose_fastest",
          [](PyRenderer& r, const std::vector<rayfold::Camera>& cameras, nb::handle folds, nb::handle aligns) {
            std::vector<rayfold::Fold> fs;
            if (!folds.is_none())
              for (nb::handle f : folds) fs.push_back(parse_fold(nb::cast<std::string>(f)));
            std::vector<int> as;
            if (!aligns.is_none())
              for (nb::handle a : aligns) as.push_back(nb::cast<int>(a));
            const rayfold::AutoChoice c = locked(*r.scene, [&] { return r.renderer->choose_fastest(cameras, fs, as); });
            nb::list predictions;
            for (const rayfold::Prediction& p : c.predictions) {
              nb::dict d;
              d["fold"] = fold_name(p.fold);
              d["kernel"] = p.kernel;
              d["align"] = p.align;
              d["name"] = p.name;
              d["trace_ms"] = p.trace_ms;
              d["update_ms"] = p.update_ms;
              d["total_ms"] = p.total_ms();
              predictions.append(d);
            }
            nb::dict out;
            out["fold"] = fold_name(c.fold);
            out["align"] = c.align;
            out["kernel"] = c.kernel;
            out["predictions"] = predictions;
            out["probe_ms"] = c.probe_ms;
            return out;
          },
          "cameras"_a, "folds"_a = nb::none(), "aligns"_a = nb::none(),
          "The fold, views per pass and (kernel='auto' on OpenCL) kernel the cost model predicts fastest for these "
          "views (docs/cost_model.md): a dict of 'fold', 'align', 'kernel', 'probe_ms' and every prediction, "
          "fastest first. folds: those to weigh (default all four); aligns: views per pass to weigh (default 1 "
          "and as many as a pass holds). The kernel chosen traces from now on. Releases the GIL.")
      .def_prop_ro("device_name", [](PyRenderer& r) { return r.renderer->device_name(); })
      .def_prop_ro("kernel", [](PyRenderer& r) { return r.renderer->kernel(); })
      .def_prop_ro(
          "tile_lanes", [](PyRenderer& r) { return r.renderer->tile_lanes(); },
          "Rays per vector of the tile kernel (8 or 16); 0 for the CPU backend.");
}

}  // namespace

NB_MODULE(_core, m) {
  m.doc() = "rayfold's C++ core; use the rayfold package.";
  m.attr("__version__") = RAYFOLD_VERSION_STRING;
  m.attr("MISS") = rayfold::kMiss;
  m.attr("DEFAULT_MATERIAL") = rayfold::kDefaultMaterial;
  nb::exception<rayfold::InputError>(m, "InputError", PyExc_ValueError);
  nb::exception<rayfold::RuntimeFailure>(m, "RuntimeFailure", PyExc_RuntimeError);

  bind_camera(m);
  bind_gbuffer(m);
  nb::class_<PyScene> scene_class = bind_scene(m);
  bind_scene_rendering(scene_class);
  bind_scene_queries(scene_class);
  bind_functions(m);
  bind_renderer(m);
}
